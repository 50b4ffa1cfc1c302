"""synthcam: synthetic camera images with exact ground truth, from Python.

The GPU renderer inverts the lens model per pixel in the shader (Brown-Conrady, fisheye,
Double Sphere), anti-aliased and deterministic; every image comes with its truth labels. The
detector, calibration and the closed-loop simulator run on the rendered pixels.

    import synthcam
    scene["facing"] = synthcam.facing(0.5, tilt_x_deg=30.0)  # or scene["pose"] = synthcam.pose(...)
    image, truth = synthcam.render(scene_toml_or_dict)      # (H, W) uint8, Truth
    found = synthcam.detect(image, "chessboard:9x6")          # Detection: points_px (N, 2)
    result = synthcam.calibrate([found, ...], "chessboard:9x6", 0.03, (1280, 1024))  # Calibration: K, dist, views
    rig = synthcam.calibrate_rig([{"name": "left", "image_size": (1280, 1024), "detections": [...]}, ...], "chessboard:8x6", 0.03)
    for image, truth in synthcam.Dataset("out/dataset"): ...
    sim = synthcam.Sim("ur5e_chessboard"); obs = sim.observe(); sim.command(qdot, 0.1)
    qdot = synthcam.servo.ibvs_velocity(sim.project, obs.q_rad, ids, error_px)  # the IBVS law, NumPy
    import synthcam.gym; env = gymnasium.make("synthcam/ServoIBVS-v0")  # pip install 'synthcam[gym]'

Pixels follow OpenCV's convention: the centre of the top-left pixel is (0, 0). Scenes, targets
and scenarios are the CLI's files (TOML or JSON text, or the same as dicts); see the repository's
README and assets/. Results are classes with NumPy arrays (``Detection``, ``Truth``,
``Calibration``, ``Pose``) that also answer ``result["key"]`` as the dicts did.
"""

from os import PathLike
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _synthcam, servo
from ._synthcam import (
    SynthcamError,
    __version__,
    adapter,
    load_image,
    render_depth_mask,
)
from .dataset import Dataset, Sample
from .poses import facing, pose, rotation_from_rvec
from .results import Calibration, CalibratedView, Detection, Observation, Pose, RigCalibration, RigCamera, Truth

_Text = Union[str, Dict[str, Any]]


class Sim:
    """A robot, a camera on its tool and a target in the loop: ``observe()`` renders the camera's
    view and detects the target (an ``Observation``), ``command(qdot, dt_s)`` moves the arm. The
    simulator runs on its own thread; every call releases the GIL. ``scenario``: a scenario file's
    text or dict, or a built-in name ("ur5e_chessboard", "course"); default "ur5e_chessboard"."""

    def __init__(self, scenario: Optional[_Text] = None, base_dir: Optional[Union[str, "PathLike[str]"]] = None) -> None:
        self._sim = _synthcam.Sim(scenario, base_dir)

    def observe(self, image: bool = False) -> Observation:
        """Render and detect at the current joints (``image=True`` keeps the frame)."""
        return Observation.from_dict(self._sim.observe(image))

    def observe_goal(self, image: bool = False) -> Observation:
        """What the camera sees from the scenario's goal pose."""
        return Observation.from_dict(self._sim.observe_goal(image))

    def command(self, qdot: Sequence[float], dt_s: float = 0.1) -> None:
        """Move the joints at ``qdot`` (rad/s) for ``dt_s`` seconds (limits enforced)."""
        self._sim.command(qdot, dt_s)

    def set_joints(self, q: Sequence[float]) -> None:
        self._sim.set_joints(q)

    def reset(self, q: Optional[Sequence[float]] = None, seed: Optional[int] = None) -> None:
        """Start an episode again: joints ``q`` (default the scenario's start), time and frame 0;
        with ``seed`` the following frames' noise is drawn from it (same ``q`` and ``seed``, same
        observations)."""
        self._sim.reset(None if q is None else list(q), seed)

    def project(self, q: Sequence[float]) -> np.ndarray:
        """The model's pixels of every feature at joints ``q`` (NaN where not seen)."""
        return self._sim.project(q)

    def close(self) -> None:
        self._sim.close()

    @property
    def info(self) -> Dict[str, Any]:
        return self._sim.info

    @property
    def dof(self) -> int:
        return self._sim.dof

    def __repr__(self) -> str:
        return repr(self._sim)


def render(scene: _Text, base_dir: Optional[Union[str, "PathLike[str]"]] = None) -> Tuple[np.ndarray, Truth]:
    """Render a scene (TOML/JSON text or a dict): ((H, W) uint8/uint16 or (H, W, 3) image, its
    ``Truth``). ``base_dir`` resolves relative mesh paths. The GIL is released while rendering."""
    image, truth = _synthcam.render(scene, base_dir)
    return image, Truth.from_dict(truth)


def detect(image: np.ndarray, target: _Text, camera: Optional[_Text] = None) -> Detection:
    """Detect a target ("chessboard:9x6", "charuco:...", "aprilgrid:...", "dot-grid:3x3",
    "s-path", or a scene's target) in a (H, W) uint8/uint16 or float image. ``camera``: the
    camera that took it (a camera file's text, or ``calibrate(...)["camera"]``); the S-path's
    dots are then placed by its pose (other targets do not use it)."""
    return Detection.from_dict(_synthcam.detect(image, target, camera))


def calibrate(
    detections: Sequence[Union[Detection, Dict[str, Any]]],
    target: _Text,
    square_m: float,
    image_size: Tuple[int, int],
    model: str = "opencv5",
    estimate_skew: bool = False,
    outlier_threshold: Optional[float] = 5.0,
) -> Calibration:
    """Calibrate from detections of a planar board (Zhang or a focal sweep, several starts and
    a perturbed-restart check, then Levenberg-Marquardt; corners beyond ``outlier_threshold``
    robust sigmas dropped, ``None`` keeps them all); see ``Calibration``. Views' poses are
    ``cam_from_target`` in the target's frame (origin at the board's outer corner)."""
    dets = [d.raw if isinstance(d, Detection) else d for d in detections]
    return Calibration.from_dict(_synthcam.calibrate(dets, target, square_m, image_size, model, estimate_skew, outlier_threshold))


def calibrate_rig(
    cameras: Sequence[Dict[str, Any]],
    target: _Text,
    square_m: float,
    model: str = "opencv5",
    outlier_threshold: Optional[float] = 5.0,
) -> RigCalibration:
    """Calibrate a camera rig: every camera's intrinsics and ``cam0_from_cam`` with the frames'
    board poses in one bundle adjustment (Kalibr's and mrcal's joint problem; OpenCV's
    ``stereoCalibrate`` for two). ``cameras``: one dict per camera, ``{"name", "image_size":
    (w, h), "detections": [one per synchronised frame, None where not seen], "model"
    (optional)}``; see ``RigCalibration``."""
    cams = [
        {**c, "detections": [d.raw if isinstance(d, Detection) else d for d in c["detections"]]}
        for c in cameras
    ]
    return RigCalibration.from_dict(_synthcam.calibrate_rig(cams, target, square_m, model, outlier_threshold))


__all__ = [
    "Calibration",
    "CalibratedView",
    "Dataset",
    "Detection",
    "Observation",
    "Pose",
    "RigCalibration",
    "RigCamera",
    "Truth",
    "Sample",
    "Sim",
    "SynthcamError",
    "__version__",
    "adapter",
    "calibrate",
    "calibrate_rig",
    "detect",
    "facing",
    "load_image",
    "pose",
    "render",
    "render_depth_mask",
    "rotation_from_rvec",
    "servo",
]
