"""synthcam: synthetic camera images with exact ground truth, from Python.

The GPU renderer inverts the lens model per pixel in the shader (Brown-Conrady, fisheye,
Double Sphere), anti-aliased and deterministic; every image comes with its truth labels. The
detector, calibration and the closed-loop simulator run on the rendered pixels.

    import synthcam
    image, truth = synthcam.render(scene_toml_or_dict)      # (H, W) uint8, dict
    found = synthcam.detect(image, "chessboard:9x6")          # points_px (N, 2)
    result = synthcam.calibrate([found, ...], "chessboard:9x6", 0.03, (1280, 1024))
    for image, truth in synthcam.Dataset("out/dataset"): ...
    sim = synthcam.Sim("ur5e_chessboard"); obs = sim.observe(); sim.command(qdot, 0.1)

Pixels follow OpenCV's convention: the centre of the top-left pixel is (0, 0). Scenes, targets
and scenarios are the CLI's files (TOML or JSON text, or the same as dicts); see the repository's
README and assets/.
"""

from ._synthcam import (
    SynthcamError,
    Sim,
    __version__,
    adapter,
    calibrate,
    detect,
    load_image,
    render,
    render_depth_mask,
)
from .dataset import Dataset, Sample

__all__ = [
    "Dataset",
    "Sample",
    "Sim",
    "SynthcamError",
    "__version__",
    "adapter",
    "calibrate",
    "detect",
    "load_image",
    "render",
    "render_depth_mask",
]
