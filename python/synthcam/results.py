"""Typed results: what ``render``, ``detect`` and ``calibrate`` return, as classes with NumPy
arrays (``K``, ``dist``, pixels, poses) instead of bare dicts.

Each keeps the dict the extension returned (``.raw``) and answers ``result["key"]`` from it, so
code written against the dicts keeps working; new code reads the attributes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Dict, List, Mapping, Optional

import numpy as np
import numpy.typing as npt

from .poses import rotation_from_rvec

Array = npt.NDArray[np.float64]


class _DictView:
    """``obj["key"]``, ``obj.get``, ``in`` and ``keys()`` answered from ``raw`` (the extension's dict)."""

    raw: Dict[str, Any]

    def __getitem__(self, key: str) -> Any:
        return self.raw[key]

    def __contains__(self, key: object) -> bool:
        return key in self.raw

    def get(self, key: str, default: Any = None) -> Any:
        return self.raw.get(key, default)

    def keys(self) -> Any:
        return self.raw.keys()


@dataclass(frozen=True)
class Pose:
    """A rigid transform ``a_from_b``: x_a = R x_b + t_m."""

    R: Array
    t_m: Array

    @staticmethod
    def from_rvec(rvec: Any, t_m: Any) -> "Pose":
        return Pose(rotation_from_rvec(rvec), np.asarray(t_m, dtype=float).reshape(3))

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> "Pose":
        """From ``{"R": 3x3, "t_m": 3}`` or ``{"rvec": 3, "t_m": 3}`` (a truth or scene ``pose``)."""
        if "R" in d:
            return Pose(np.asarray(d["R"], dtype=float).reshape(3, 3), np.asarray(d["t_m"], dtype=float).reshape(3))
        return Pose.from_rvec(d["rvec"], d["t_m"])

    @property
    def rvec(self) -> Array:
        """Rotation vector (Rodrigues, radians; OpenCV's ``cv2.Rodrigues`` inverse)."""
        c = np.clip((np.trace(self.R) - 1.0) / 2.0, -1.0, 1.0)
        theta = float(np.arccos(c))
        w = np.array([self.R[2, 1] - self.R[1, 2], self.R[0, 2] - self.R[2, 0], self.R[1, 0] - self.R[0, 1]])
        if theta < 1e-8:
            return 0.5 * w
        if np.pi - theta < 1e-6:  # near a half turn: the axis from R + I
            m = (self.R + np.eye(3)) / 2.0
            axis = m[:, int(np.argmax(np.diag(m)))]
            return theta * axis / np.linalg.norm(axis)
        return theta * w / (2.0 * np.sin(theta))

    def matrix(self) -> Array:
        """The 4 x 4 homogeneous matrix."""
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = self.R, self.t_m
        return m

    def inverse(self) -> "Pose":
        return Pose(self.R.T, -self.R.T @ self.t_m)

    def apply(self, points: Any) -> Array:
        """Points (N, 3) of frame b in frame a."""
        return np.asarray(points, dtype=float) @ self.R.T + self.t_m

    def __matmul__(self, other: "Pose") -> "Pose":
        return Pose(self.R @ other.R, self.R @ other.t_m + self.t_m)


def _array(v: Any, dtype: Any = float) -> Optional[np.ndarray]:
    return None if v is None else np.asarray(v, dtype=dtype)


@dataclass(frozen=True)
class Detection(_DictView):
    """What ``detect`` found. ``points_px`` (N, 2), OpenCV's pixel convention."""

    found: bool
    points_px: Array
    ids: Optional[npt.NDArray[np.int64]]
    """Coded boards: each point's id (ChArUco: OpenCV's chessboard-corner id)."""
    indices: Optional[npt.NDArray[np.int64]]
    """S-path: each point's path index."""
    untrusted: List[int]
    """Chessboards: points the refinement cannot place within 0.1 px (a calibration leaves out
    those whose fit failed or that are far worse than their view's median)."""
    position_sigma_px: Optional[Array]
    """Chessboards: each point's standard deviation from its own fit, px (inf where it failed)."""
    note: Optional[str]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> "Detection":
        sigma = d.get("position_sigma_px")
        if sigma is not None:
            sigma = np.array([np.inf if s is None else s for s in sigma], dtype=float)
        raw = dict(d, position_sigma_px=None if sigma is None else sigma.tolist())
        return Detection(
            found=bool(d.get("found", False)),
            points_px=np.asarray(d.get("points_px", np.zeros((0, 2))), dtype=float).reshape(-1, 2),
            ids=_array(d.get("ids"), np.int64),
            indices=_array(d.get("indices"), np.int64),
            untrusted=list(d.get("untrusted") or []),
            position_sigma_px=sigma,
            note=d.get("note"),
            raw=raw,
        )


@dataclass(frozen=True)
class Truth(_DictView):
    """The renderer's truth labels of one image (the truth JSON): the camera, ``cam_from_target``
    and every feature's exact pixel, target point, depth and visibility."""

    camera: Dict[str, Any]
    cam_from_target: Pose
    features: List[Dict[str, Any]]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @staticmethod
    def from_dict(d: Dict[str, Any]) -> "Truth":
        return Truth(camera=d.get("camera", {}), cam_from_target=Pose.from_dict(d["cam_from_target"]), features=list(d.get("features", [])), raw=d)

    @property
    def pixels_px(self) -> Array:
        """(N, 2): every feature's exact pixel."""
        return np.array([f["pixel_px"] for f in self.features], dtype=float).reshape(-1, 2)

    @property
    def points_target_m(self) -> Array:
        """(N, 3): every feature's point in the target frame."""
        return np.array([f["point_target_m"] for f in self.features], dtype=float).reshape(-1, 3)

    @property
    def visible(self) -> npt.NDArray[np.bool_]:
        """(N,): whether each feature is seen (in front, in the image, not hidden)."""
        return np.array([bool(f.get("visible", True)) for f in self.features], dtype=bool)


@dataclass(frozen=True)
class CalibratedView:
    """One view of a calibration: its ``cam_from_target`` and reprojection errors."""

    cam_from_target: Pose
    rms_px: float
    max_px: float
    outliers: List[int] = field(default_factory=list)
    """Indices (into the detection's ``points_px``) dropped as outliers."""


@dataclass(frozen=True)
class Calibration(_DictView):
    """What ``calibrate`` estimated."""

    rms_px: float
    model: str
    K: Array
    """3 x 3 camera matrix."""
    dist: Array
    """Lens parameters: OpenCV's coefficients in OpenCV's order; fisheye k1..k4; Double Sphere xi, alpha."""
    camera: Dict[str, Any]
    """The scene-file camera table (usable in a scene dict)."""
    std: Dict[str, float]
    """Standard deviation of each estimated intrinsic, by name."""
    views: List[CalibratedView]
    used: List[int]
    """Index into the detections of each view used."""
    iterations: int
    converged: bool
    raw: Dict[str, Any] = field(repr=False, compare=False)
    outliers_dropped: int = 0
    """Points dropped as outliers over all views (``raw["rms_before_rejection_px"]``: the RMS with them)."""
    undetermined: List[str] = field(default_factory=list)
    """Intrinsics the views do not determine (left out of ``std``: their sigma is infinite)."""
    uncertainty_inside_px: float = 0.0
    """Worst projection sigma inside the area the views cover, px (at infinity)."""
    uncertainty_outside_px: float = 0.0
    """Worst projection sigma outside it, px (NaN when the views cover every cell)."""

    @staticmethod
    def from_dict(d: Dict[str, Any]) -> "Calibration":
        views = [
            CalibratedView(Pose.from_rvec(v["rvec"], v["tvec"]), float(v["rms_px"]), float(v["max_px"]), [int(i) for i in v.get("outliers", [])])
            for v in d["views"]
        ]
        return Calibration(
            rms_px=float(d["rms_px"]),
            model=d["model"],
            K=np.asarray(d["K"], dtype=float),
            dist=np.asarray(d["dist"], dtype=float),
            camera=d["camera"],
            std=dict(d["std"]),
            views=views,
            used=list(d["used"]),
            iterations=int(d["iterations"]),
            converged=bool(d["converged"]),
            raw=d,
            outliers_dropped=int(d.get("outliers_dropped", 0)),
            undetermined=list(d.get("undetermined", [])),
            uncertainty_inside_px=_float_or_nan(d.get("uncertainty_inside_px")),
            uncertainty_outside_px=_float_or_nan(d.get("uncertainty_outside_px")),
        )


@dataclass(frozen=True)
class RigCamera:
    """One camera of a ``RigCalibration``."""

    name: str
    model: str
    K: Array
    dist: Array
    camera: Dict[str, Any]
    """The scene-file camera table."""
    cam0_from_cam: Pose
    """This camera's pose in the first camera's frame (identity for the first)."""
    rotation_std_deg: Array
    """Standard deviation of ``cam0_from_cam``'s rotation vector, degrees."""
    translation_std_m: Array
    """Standard deviation of its translation, metres."""
    rms_px: float
    views: int


@dataclass(frozen=True)
class RigCalibration(_DictView):
    """What ``calibrate_rig`` estimated."""

    rms_px: float
    """Over every camera's points (as OpenCV's ``stereoCalibrate`` returns it)."""
    cameras: List[RigCamera]
    iterations: int
    rectified_row_error_mean_px: float
    """The first two cameras' corners after OpenCV's stereo rectification: row difference, px."""
    rectified_row_error_max_px: float
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @staticmethod
    def from_dict(d: Dict[str, Any]) -> "RigCalibration":
        cams = [
            RigCamera(
                name=c["name"],
                model=c["model"],
                K=np.asarray(c["K"], dtype=float),
                dist=np.asarray(c["dist"], dtype=float),
                camera=c["camera"],
                cam0_from_cam=Pose.from_dict(c["cam0_from_cam"]),
                rotation_std_deg=np.asarray(c["rotation_std_deg"], dtype=float),
                translation_std_m=np.asarray(c["translation_std_m"], dtype=float),
                rms_px=float(c["rms_px"]),
                views=int(c["views"]),
            )
            for c in d["cameras"]
        ]
        return RigCalibration(
            rms_px=float(d["rms_px"]),
            cameras=cams,
            iterations=int(d["iterations"]),
            rectified_row_error_mean_px=_float_or_nan(d.get("rectified_row_error_mean_px")),
            rectified_row_error_max_px=_float_or_nan(d.get("rectified_row_error_max_px")),
            raw=d,
        )


def _float_or_nan(v: Any) -> float:
    return float("nan") if v is None else float(v)


def _pose_of_rows(rows: Any) -> Pose:
    m = np.asarray(rows, dtype=float).reshape(4, 4)
    return Pose(m[:3, :3].copy(), m[:3, 3].copy())


@dataclass(frozen=True)
class Observation(_DictView):
    """One step of ``Sim``: the features detected in the rendered frame, the arm's joints, and the
    truth (poses, every feature's exact pixel)."""

    frame: int
    time_s: float
    q_rad: Array
    ids: npt.NDArray[np.int64]
    """The id of each detected feature (an index into the target's features)."""
    pixels_px: Array
    """(N, 2): the detected pixels, OpenCV's convention."""
    note: Optional[str]
    render_ms: float
    detect_ms: float
    cam_from_target: Pose
    world_from_cam: Pose
    truth_px: Array
    """(features, 2): every feature's exact pixel (NaN where it is not seen)."""
    image: Optional[np.ndarray]
    raw: Dict[str, Any] = field(repr=False, compare=False)

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> "Observation":
        return Observation(
            frame=int(d["frame"]),
            time_s=float(d["time_s"]),
            q_rad=np.asarray(d["q_rad"], dtype=float),
            ids=np.asarray(d["ids"], dtype=np.int64),
            pixels_px=np.asarray(d["pixels_px"], dtype=float).reshape(-1, 2),
            note=d.get("note"),
            render_ms=float(d["render_ms"]),
            detect_ms=float(d["detect_ms"]),
            cam_from_target=_pose_of_rows(d["cam_from_target"]),
            world_from_cam=_pose_of_rows(d["world_from_cam"]),
            truth_px=np.asarray(d["truth_px"], dtype=float).reshape(-1, 2),
            image=d.get("image"),
            raw=dict(d),
        )
