"""Typed stubs of the extension module `synthcam._synthcam` (written by hand beside the Rust
source in python/src/; the docstrings there are the reference)."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, TypedDict, Union, final

import numpy as np
import numpy.typing as npt

__all__ = ["Sim", "SynthcamError", "__version__", "adapter", "calibrate", "calibrate_rig", "detect", "load_image", "render", "render_depth_mask"]
__version__: str

_Text = Union[str, Dict[str, Any]]
"""A scene, target or scenario: TOML or JSON text, or the same as a dict."""

class SynthcamError(Exception):
    """An error of the synthcam library; the message gives the cause chain."""

class _Detection(TypedDict):
    found: bool
    points_px: npt.NDArray[np.float64]
    ids: Optional[List[int]]
    indices: Optional[List[int]]
    untrusted: List[int]
    position_sigma_px: Optional[List[Optional[float]]]
    note: Optional[str]

class _Observation(TypedDict):
    frame: int
    time_s: float
    q_rad: List[float]
    ids: List[int]
    pixels_px: npt.NDArray[np.float64]
    note: Optional[str]
    render_ms: float
    detect_ms: float
    cam_from_target: List[List[float]]
    world_from_cam: List[List[float]]
    truth_px: npt.NDArray[np.float64]
    image: Optional[np.ndarray]

def render(scene: _Text, base_dir: Optional[Union[str, PathLike[str]]] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
    """Render a scene: ((H, W) uint8/uint16 or (H, W, 3) image, truth dict). GIL released."""

def render_depth_mask(scene: _Text, base_dir: Optional[Union[str, PathLike[str]]] = None) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.uint16]]:
    """(depth in metres along the camera's z, NaN where nothing, +inf on a panorama; instance ids: 0 none, 1 target, 2+i object i, 65535 a background image)."""

def adapter() -> str:
    """The GPU adapter the renderer runs on, opening it if needed."""

def load_image(path: Union[str, PathLike[str]]) -> np.ndarray:
    """Read a PNG or JPEG as stored: (H, W) uint8/uint16, or (H, W, 3)."""

def detect(image: np.ndarray, target: _Text, camera: Optional[_Text] = None) -> _Detection:
    """Detect a target ("chessboard:9x6", "charuco:...", "aprilgrid:...", "dot-grid:3x3", "s-path", or a scene)."""

def calibrate(
    detections: Sequence[Union[_Detection, Dict[str, Any]]],
    target: _Text,
    square_m: float,
    image_size: Tuple[int, int],
    model: str = "opencv5",
    estimate_skew: bool = False,
    outlier_threshold: Optional[float] = 5.0,
) -> Dict[str, Any]:
    """Global search + Levenberg-Marquardt + outlier rejection: rms_px, K, dist, camera, std, views, used, iterations, converged, outliers_dropped, rms_before_rejection_px, uncertainty_inside_px, uncertainty_outside_px."""

def calibrate_rig(
    cameras: Sequence[Dict[str, Any]],
    target: _Text,
    square_m: float,
    model: str = "opencv5",
    outlier_threshold: Optional[float] = 5.0,
) -> Dict[str, Any]:
    """Joint rig calibration: rms_px, cameras (name, model, K, dist, camera, cam0_from_cam, rotation_std_deg, translation_std_m, rms_px, views), iterations, rectified_row_error_mean_px, rectified_row_error_max_px."""

@final
class Sim:
    """A robot, a camera on its tool and a target in the loop (render, detect, command, move)."""

    def __new__(cls, scenario: Optional[_Text] = None, base_dir: Optional[Union[str, PathLike[str]]] = None) -> "Sim": ...
    def observe(self, image: bool = False) -> _Observation: ...
    def observe_goal(self, image: bool = False) -> _Observation: ...
    def command(self, qdot: Sequence[float], dt_s: float = 0.1) -> None: ...
    def set_joints(self, q: Sequence[float]) -> None: ...
    def reset(self, q: Optional[Sequence[float]] = None, seed: Optional[int] = None) -> None: ...
    def project(self, q: Sequence[float]) -> npt.NDArray[np.float64]: ...
    def close(self) -> None: ...
    @property
    def info(self) -> Dict[str, Any]: ...
    @property
    def dof(self) -> int: ...
