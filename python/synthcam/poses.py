"""Pose helpers for scene dicts: ``facing`` (the board's centre on the optical axis, by distance
and tilts: the Rust ``synthcam::scene::Facing``) and ``pose`` (an explicit ``cam_from_target``).

    scene["facing"] = synthcam.facing(0.5, tilt_x_deg=30.0)          # the `[facing]` table
    scene["pose"] = synthcam.pose(rvec=[0.1, 0.0, 0.0], t_m=[0, 0, 1])  # the `[pose]` table

A scene takes one of the two keys. ``rotation_from_rvec`` is Rodrigues' formula (OpenCV's
``cv2.Rodrigues``), for checking poses a calibration returns.
"""

from typing import Dict, Optional, Sequence

import numpy as np
import numpy.typing as npt


def _finite(name: str, values: Sequence[float]) -> list:
    out = [float(v) for v in np.asarray(values, dtype=float).ravel()]
    if not all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite, got {values!r}")
    return out


def facing(distance_m: float, tilt_x_deg: float = 0.0, tilt_y_deg: float = 0.0, roll_deg: float = 0.0) -> Dict[str, float]:
    """The ``facing`` table: the target's centre ``distance_m`` along the optical axis, turned by
    ``tilt_x_deg`` about the camera's x axis, then ``tilt_y_deg`` about y, then ``roll_deg`` about
    the optical axis (all zero: facing the camera)."""
    d, tx, ty, roll = _finite("facing", [distance_m, tilt_x_deg, tilt_y_deg, roll_deg])
    if d <= 0.0:
        raise ValueError(f"distance_m must be positive, got {distance_m}")
    return {"distance_m": d, "tilt_x_deg": tx, "tilt_y_deg": ty, "roll_deg": roll}


def pose(t_m: Sequence[float], R: Optional[npt.ArrayLike] = None, rvec: Optional[Sequence[float]] = None) -> Dict[str, list]:
    """The ``pose`` table of ``cam_from_target`` (x_cam = R x_target + t_m): give ``R`` (3 x 3) or
    ``rvec`` (Rodrigues, radians)."""
    if (R is None) == (rvec is None):
        raise ValueError("give R or rvec, not both or neither")
    t = _finite("t_m", t_m)
    if len(t) != 3:
        raise ValueError(f"t_m must have 3 values, got {len(t)}")
    if rvec is not None:
        r = _finite("rvec", rvec)
        if len(r) != 3:
            raise ValueError(f"rvec must have 3 values, got {len(r)}")
        return {"rvec": r, "t_m": t}
    m = np.asarray(R, dtype=float)
    if m.shape != (3, 3):
        raise ValueError(f"R must be 3 x 3, got shape {m.shape}")
    return {"R": [_finite("R", row) for row in m], "t_m": t}


def rotation_from_rvec(rvec: Sequence[float]) -> npt.NDArray[np.float64]:
    """Rodrigues' formula: the rotation matrix of a rotation vector (radians)."""
    r = np.asarray(_finite("rvec", rvec), dtype=float)
    theta = float(np.linalg.norm(r))
    if theta < 1e-12:
        return np.eye(3)
    k = r / theta
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(theta) * kx + (1.0 - np.cos(theta)) * (kx @ kx)
