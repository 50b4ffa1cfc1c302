"""Log a servo run to a rerun recording (``.rrd``): every frame, the detected, true and desired
features, the camera's pose and frustum, the target's pose, the joints and the error curves, on
rerun's timelines.

    from synthcam.rerun_log import Recorder, record_servo
    summary = record_servo("run.rrd", "ur5e_chessboard", steps=100)   # IBVS, every step logged
    # or log your own loop:
    with Recorder("run.rrd", sim.info) as rec:
        rec.log_goal(sim.observe_goal())
        for k in range(100):
            obs = sim.observe(image=True)
            rec.log(k, obs)
            ...

    python -m synthcam.rerun_log --scenario ur5e_chessboard --steps 100 -o run.rrd
    rerun run.rrd                                                    # the viewer

Timelines: ``step`` (a sequence: the step index given to ``Recorder.log``) and ``sim_time`` (a
duration: the simulator's ``Observation.time_s``).

Entities (``Recorder.ENTITIES``): ``world`` (right-handed, Z up: the simulator's world frame),
``world/camera`` (``Transform3D``: ``world_from_cam``), ``world/camera/image`` (``Pinhole``, the
camera's intrinsics, static; and the frame, ``Image``), ``world/camera/image/detected``,
``.../truth`` and ``.../desired`` (``Points2D``, the feature ids as ``keypoint_ids``),
``world/target`` (``Transform3D``: ``world_from_target = world_from_cam @ cam_from_target``),
``world/goal_camera`` and ``world/goal_camera/image`` (the goal pose's frustum, static, after
``log_goal``), ``joints/q<i>`` (rad), ``command/qdot<i>`` (rad/s, ``log_command``),
``error/pixel_rms_px`` (detected vs desired, over the ids in both), ``error/detection_rms_px``
(detected vs truth), ``features/detected``, ``features/matched``, ``timing/render_ms``,
``timing/detect_ms`` (``Scalars``) and ``camera_info`` (a markdown ``TextDocument``: the lens
model and its distortion coefficients, which rerun's ``Pinhole`` cannot show).

Pixel convention: synthcam's pixels follow OpenCV's (the centre of the top-left pixel is (0, 0));
rerun's 2-D image space puts the top-left pixel's *corner* at (0, 0), its centre at (0.5, 0.5)
(the viewer draws an image over [0, W] x [0, H]). So that overlays land on the pixels they name,
the recorder logs every 2-D position **shifted by +0.5** (``Recorder.PIXEL_OFFSET``) and the
pinhole's principal point likewise (``cx + 0.5``, ``cy + 0.5``): 3-D points projected by rerun's
pinhole land where synthcam's model puts them, up to the lens distortion, which rerun ignores.
Subtract ``PIXEL_OFFSET`` from positions read back from the file to get OpenCV pixels again.

The file is written to ``<path>.partial`` and renamed to ``path`` by ``close()`` (or leaving a
``with`` block normally): a run that fails leaves no file at ``path`` (``abort()`` deletes the
partial one; the viewer can tail ``<path>.partial`` while it is written).

Needs rerun-sdk >= 0.23 (``pip install 'synthcam[rerun]'`` or ``pip install rerun-sdk``), imported
only when a ``Recorder`` is built: ``import synthcam`` and ``import synthcam.rerun_log`` work
without it.
"""

import argparse
import importlib
import io
import json
import math
import os
import sys
import time
import uuid
from pathlib import Path
from types import TracebackType
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Type, Union

import numpy as np
import numpy.typing as npt

from . import Observation, Sim, SynthcamError
from .servo import desired_pixels, ibvs_velocity, matched_error, rms_px

_PathLike = Union[str, "os.PathLike[str]"]
Desired = Union[Observation, Mapping[int, Sequence[float]]]
"""Desired features: an ``Observation`` (its ``ids`` and ``pixels_px``) or ``{id: (u, v)}`` (px,
OpenCV's convention)."""

_INSTALL_HINT = "pip install rerun-sdk (or pip install 'synthcam[rerun]')"


def _import_rerun() -> Any:
    """The ``rerun`` module (typed Any: rerun's own types are not needed to log, and mypy must pass
    with and without rerun-sdk installed)."""
    try:
        rr: Any = importlib.import_module("rerun")
    except ImportError as e:
        raise ImportError(f"synthcam.rerun_log needs rerun-sdk >= 0.23: {_INSTALL_HINT}") from e
    if not hasattr(rr, "Scalars") or not hasattr(rr.RecordingStream, "set_time"):
        version = getattr(rr, "__version__", "?")
        raise ImportError(f"synthcam.rerun_log needs rerun-sdk >= 0.23 (rr.Scalars, set_time), found {version}: {_INSTALL_HINT}")
    return rr


class Recorder:
    """Logs a servo run's observations to a rerun ``.rrd`` file (see the module's docstring for
    the entities, timelines and the pixel convention).

    Parameters
    ----------
    path : str or PathLike
        The ``.rrd`` file to write; its directory must exist. Written as ``<path>.partial``,
        renamed to ``path`` by ``close()``.
    sim_info : dict
        ``Sim.info``: the camera (``width``, ``height``, ``fx``, ``fy``, ``cx``, ``cy``, ``skew``,
        ``model``, ``dist``), ``robot`` and ``dof``.
    application_id : str
        rerun's application id (the viewer groups recordings by it).
    recording_name : str, optional
        A name shown by the viewer (default: "synthcam <robot>").
    jpeg_quality : int, optional
        Store frames as JPEG of this quality (1-100; 8-bit frames only; needs Pillow) instead of
        raw pixels: about 5x smaller files, lossy. Default: raw, lossless.

    Raises
    ------
    ImportError
        rerun-sdk (>= 0.23) is not installed.
    FileNotFoundError, NotADirectoryError, IsADirectoryError, PermissionError
        ``path`` cannot be written (nothing is created).
    """

    PIXEL_OFFSET = 0.5
    """Added to every OpenCV pixel (and the principal point) logged: rerun's image space puts the
    top-left pixel's centre at (0.5, 0.5)."""

    ENTITIES = (
        "world",
        "world/camera",
        "world/camera/image",
        "world/camera/image/detected",
        "world/camera/image/truth",
        "world/camera/image/desired",
        "world/target",
        "world/goal_camera",
        "world/goal_camera/image",
        "error/pixel_rms_px",
        "error/detection_rms_px",
        "features/detected",
        "features/matched",
        "timing/render_ms",
        "timing/detect_ms",
        "camera_info",
    )
    """The entity paths of a run (with ``joints/q<i>``; ``world/goal_camera*`` come with
    ``log_goal(Observation)``, ``command/qdot<i>`` with ``log_command``, as ``record_servo`` calls
    them)."""

    def __init__(
        self,
        path: _PathLike,
        sim_info: Mapping[str, Any],
        application_id: str = "synthcam",
        recording_name: Optional[str] = None,
        jpeg_quality: Optional[int] = None,
    ) -> None:
        rr = _import_rerun()
        self._rr = rr
        self.path = Path(path)
        self.partial_path = self.path.with_name(self.path.name + ".partial")
        _check_writable(self.path)
        if jpeg_quality is not None and not (1 <= int(jpeg_quality) <= 100):
            raise ValueError(f"jpeg_quality must be in 1..100 (or None for raw frames), got {jpeg_quality}")
        self.jpeg_quality = None if jpeg_quality is None else int(jpeg_quality)

        cam = sim_info["camera"]
        self.width, self.height = int(cam["width"]), int(cam["height"])
        self.dof = int(sim_info.get("dof", len(sim_info.get("q_start_rad", []))))
        o = self.PIXEL_OFFSET
        # OpenCV's K with the principal point moved into rerun's pixel-corner convention
        self.image_from_camera = np.array(
            [[float(cam["fx"]), float(cam.get("skew", 0.0)), float(cam["cx"]) + o], [0.0, float(cam["fy"]), float(cam["cy"]) + o], [0.0, 0.0, 1.0]]
        )
        self._desired: Dict[int, npt.NDArray[np.float64]] = {}
        self._closed = False
        self.steps: List[int] = []

        # The stream is typed Any: rerun's classes need not be known to mypy (see _import_rerun).
        self._rec: Any = rr.RecordingStream(application_id, recording_id=uuid.uuid4())
        try:
            self._rec.save(str(self.partial_path))
        except RuntimeError as e:  # rerun reports a file it cannot create as RuntimeError
            raise OSError(f"cannot write the rerun recording {self.partial_path}: {e}") from e
        try:
            self._log_static(sim_info, recording_name)
        except BaseException:
            self.abort()
            raise

    # -- static data -------------------------------------------------------------------------

    def _pinhole(self, plane_m: float = 0.1) -> Any:
        rr = self._rr
        return rr.Pinhole(
            image_from_camera=self.image_from_camera,
            resolution=[self.width, self.height],
            camera_xyz=rr.ViewCoordinates.RDF,  # OpenCV's camera frame: x right, y down, z forward
            image_plane_distance=plane_m,
        )

    def _log_static(self, sim_info: Mapping[str, Any], recording_name: Optional[str]) -> None:
        rr, rec = self._rr, self._rec
        cam = sim_info["camera"]
        robot = str(sim_info.get("robot", "robot"))
        rec.send_recording_name(recording_name or f"synthcam {robot}")
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        rec.log("world/camera/image", self._pinhole(), static=True)
        if hasattr(rr, "TransformAxes3D"):
            rec.log("world/camera", rr.TransformAxes3D(0.05), static=True)
            rec.log("world/target", rr.TransformAxes3D(0.1), static=True)
        dist = [float(d) for d in cam.get("dist", [])]
        distorted = any(d != 0.0 for d in dist)
        text = "\n".join(
            [
                f"# {robot}: camera",
                "",
                f"- image: {self.width} x {self.height} px",
                f"- model: `{cam.get('model', '?')}`, distortion coefficients `{dist}`",
                f"- K (OpenCV): fx = {cam['fx']}, fy = {cam['fy']}, cx = {cam['cx']}, cy = {cam['cy']}, skew = {cam.get('skew', 0.0)}",
                "",
                (
                    "**rerun's Pinhole shows no lens distortion**: the frustum and any 3-D point rerun projects use the "
                    "undistorted pinhole; the image and the 2-D features are the distorted (real) ones."
                    if distorted
                    else "No lens distortion: rerun's Pinhole is the whole camera model."
                ),
                "",
                f"2-D positions are OpenCV pixels + {self.PIXEL_OFFSET} (rerun puts the top-left pixel's centre at "
                f"(0.5, 0.5)); the Pinhole's principal point is (cx + {self.PIXEL_OFFSET}, cy + {self.PIXEL_OFFSET}).",
            ]
        )
        rec.log("camera_info", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)
        for i in range(self.dof):
            rec.log(f"joints/q{i}", rr.SeriesLines(names=f"q{i} (rad)"), static=True)
        for entity, name in (
            ("error/pixel_rms_px", "detected vs desired RMS (px)"),
            ("error/detection_rms_px", "detected vs truth RMS (px)"),
            ("timing/render_ms", "render (ms)"),
            ("timing/detect_ms", "detect (ms)"),
        ):
            rec.log(entity, rr.SeriesLines(names=name), static=True)

    def _points(self, pixels: npt.ArrayLike, ids: npt.ArrayLike, color: Tuple[int, int, int], radius: float, order: float) -> Any:
        rr = self._rr
        pos = np.asarray(pixels, dtype=np.float64).reshape(-1, 2) + self.PIXEL_OFFSET
        return rr.Points2D(
            pos.astype(np.float32),
            keypoint_ids=np.asarray(ids, dtype=np.uint16),
            colors=color,
            radii=rr.Radius.ui_points(radius),
            draw_order=order,
        )

    # -- per step ----------------------------------------------------------------------------

    def log_goal(self, goal: Desired) -> None:
        """The desired features (logged at every following step as ``world/camera/image/desired``)
        and, for an ``Observation`` (``Sim.observe_goal()``), the goal camera's pose and frustum
        (``world/goal_camera``, static)."""
        self._check_open()
        self._desired = desired_pixels(goal)
        if isinstance(goal, Observation):
            m = goal.world_from_cam.matrix()
            self._rec.log("world/goal_camera", self._rr.Transform3D(translation=m[:3, 3], mat3x3=m[:3, :3]), static=True)
            self._rec.log("world/goal_camera/image", self._pinhole(), static=True)

    def log(self, step: int, obs: Observation, desired: Optional[Desired] = None) -> Dict[str, float]:
        """Log one step: at ``step`` on the ``step`` timeline and ``obs.time_s`` on ``sim_time``.

        ``desired`` replaces the goal of ``log_goal`` from this step on. Returns the errors logged:
        ``pixel_rms_px`` (detected vs desired over the ids in both; NaN, and not logged, when none
        match) and ``detection_rms_px`` (detected vs truth; NaN when nothing is detected).
        """
        self._check_open()
        rr, rec = self._rr, self._rec
        if desired is not None:
            self._desired = desired_pixels(desired)
        rec.set_time("step", sequence=int(step))
        rec.set_time("sim_time", duration=float(obs.time_s))
        self.steps.append(int(step))

        w_c = obs.world_from_cam.matrix()
        w_t = w_c @ obs.cam_from_target.matrix()
        rec.log("world/camera", rr.Transform3D(translation=w_c[:3, 3], mat3x3=w_c[:3, :3]))
        rec.log("world/target", rr.Transform3D(translation=w_t[:3, 3], mat3x3=w_t[:3, :3]))
        if obs.image is not None:
            image = rr.Image(np.asarray(obs.image))
            if self.jpeg_quality is not None and np.asarray(obs.image).dtype == np.uint8:
                image = image.compress(jpeg_quality=self.jpeg_quality)
            rec.log("world/camera/image", image)

        ids = np.asarray(obs.ids, dtype=np.int64)
        rec.log("world/camera/image/detected", self._points(obs.pixels_px, ids, (40, 220, 40), 3.0, 30.0))
        seen = np.flatnonzero(np.all(np.isfinite(obs.truth_px), axis=1))
        rec.log("world/camera/image/truth", self._points(obs.truth_px[seen], seen, (60, 150, 255), 1.5, 40.0))
        want = sorted(self._desired)
        rec.log(
            "world/camera/image/desired",
            self._points([self._desired[i] for i in want] if want else np.zeros((0, 2)), want, (255, 60, 60), 4.0, 20.0),
        )

        for i, q in enumerate(np.asarray(obs.q_rad, dtype=float)):
            rec.log(f"joints/q{i}", rr.Scalars(float(q)))
        common, err = matched_error(obs, self._desired)
        pixel_rms = rms_px(err) if common else math.nan
        if common:
            rec.log("error/pixel_rms_px", rr.Scalars(pixel_rms))
        truth = obs.truth_px[ids] if len(ids) else np.zeros((0, 2))
        ok = np.all(np.isfinite(truth), axis=1)
        detection_rms = rms_px(obs.pixels_px[ok] - truth[ok]) if ok.any() else math.nan
        if ok.any():
            rec.log("error/detection_rms_px", rr.Scalars(detection_rms))
        rec.log("features/detected", rr.Scalars(float(len(ids))))
        rec.log("features/matched", rr.Scalars(float(len(common))))
        rec.log("timing/render_ms", rr.Scalars(float(obs.render_ms)))
        rec.log("timing/detect_ms", rr.Scalars(float(obs.detect_ms)))
        return {"pixel_rms_px": pixel_rms, "detection_rms_px": detection_rms}

    def log_command(self, step: int, qdot: npt.ArrayLike) -> None:
        """The joint velocities (rad/s) commanded after ``step``'s observation: ``command/qdot<i>``."""
        self._check_open()
        self._rec.set_time("step", sequence=int(step))
        for i, v in enumerate(np.asarray(qdot, dtype=float).reshape(-1)):
            self._rec.log(f"command/qdot{i}", self._rr.Scalars(float(v)))

    # -- the file ----------------------------------------------------------------------------

    def close(self) -> None:
        """Flush everything to the file and move it to ``path`` (a second call does nothing)."""
        if self._closed:
            return
        self._closed = True
        self._rec.flush()
        self._rec.disconnect()
        os.replace(self.partial_path, self.path)

    def abort(self) -> None:
        """Stop logging and delete the partial file: nothing is left at ``path``."""
        if self._closed:
            return
        self._closed = True
        try:
            self._rec.disconnect()
        finally:
            if self.partial_path.exists():
                self.partial_path.unlink()

    def _check_open(self) -> None:
        if self._closed:
            raise ValueError(f"the recorder of {self.path} is closed")

    def __enter__(self) -> "Recorder":
        return self

    def __exit__(self, exc_type: Optional[Type[BaseException]], exc: Optional[BaseException], tb: Optional[TracebackType]) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"<Recorder {str(self.path)!r} {self.width}x{self.height} steps={len(self.steps)} {state}>"


class RecordedRun:
    """A ``.rrd`` file read back with rerun-sdk's reader (``rerun.chunk.RrdReader``, rerun-sdk
    0.41): every component's rows by entity and ``step``, for tests and quick checks.

    ``entities`` lists the entity paths (no leading "/"); ``value(entity, component, step)`` is a
    row as a NumPy array (``step=None``: the static row), e.g. ``value("world/camera/image/detected",
    "Points2D:positions", 3)`` the (N, 2) float32 positions, in rerun's pixel convention (OpenCV's
    pixels + ``Recorder.PIXEL_OFFSET``); ``scalars(entity)`` a curve as (steps, values);
    ``image(step)`` a raw frame as (H, W[, C]); ``frames`` the steps with a frame.
    """

    def __init__(self, path: _PathLike, timeline: str = "step") -> None:
        rr = _import_rerun()
        chunk: Any = importlib.import_module("rerun.chunk")
        if not hasattr(chunk, "RrdReader"):
            raise ImportError(f"reading a recording back needs rerun.chunk.RrdReader (rerun-sdk 0.41), found rerun-sdk {rr.__version__}")
        self._rr = rr
        self.path = Path(path)
        self.bytes = self.path.stat().st_size
        self.timeline = timeline
        self._rows: Dict[Tuple[str, str], Dict[Optional[int], Any]] = {}
        for ch in chunk.RrdReader(str(self.path)).store().stream():
            entity = str(ch.entity_path).lstrip("/")
            if entity.startswith("__"):  # recording properties
                continue
            batch = ch.to_record_batch()
            names = batch.schema.names
            if ch.is_static:
                steps: List[Optional[int]] = [None] * batch.num_rows
            elif timeline in names:
                steps = [int(s) for s in batch.column(timeline).to_pylist()]
            else:  # rows on other timelines only
                continue
            for field in batch.schema:
                if (field.metadata or {}).get(b"rerun:kind") != b"data":
                    continue
                rows = self._rows.setdefault((entity, field.name), {})
                column = batch.column(field.name)
                for r, s in enumerate(steps):
                    rows[s] = column[r]

    @property
    def entities(self) -> List[str]:
        return sorted({e for e, _ in self._rows})

    def components(self, entity: str) -> List[str]:
        return sorted(c for e, c in self._rows if e == entity)

    def steps(self, entity: str, component: str) -> List[int]:
        """The steps at which ``entity`` has a ``component`` row (static rows left out)."""
        return sorted(s for s in self._rows.get((entity, component), {}) if s is not None)

    def value(self, entity: str, component: str, step: Optional[int] = None) -> np.ndarray:
        """The row of ``component`` at ``step`` (``None``: static) as a NumPy array."""
        cell = self._rows[(entity, component)][step]
        values = cell.values
        if values is not None and hasattr(values, "flatten") and values.null_count == 0:
            try:
                flat = np.asarray(values.flatten().to_numpy(zero_copy_only=False))
                return flat.reshape(len(values), -1) if len(values) and flat.size != len(values) else flat
            except Exception:  # nested or non-numeric types: the Python objects
                pass
        return np.asarray(cell.as_py())

    def scalars(self, entity: str) -> Tuple[np.ndarray, np.ndarray]:
        """A ``Scalars`` curve: (steps, values)."""
        steps = self.steps(entity, "Scalars:scalars")
        return np.asarray(steps, dtype=np.int64), np.array([float(self.value(entity, "Scalars:scalars", s).reshape(-1)[0]) for s in steps])

    @property
    def frames(self) -> List[int]:
        """The steps with a frame (raw ``Image`` or JPEG ``EncodedImage``) at ``world/camera/image``."""
        entity = "world/camera/image"
        return sorted(set(self.steps(entity, "Image:buffer")) | set(self.steps(entity, "EncodedImage:blob")))

    def image(self, step: int, entity: str = "world/camera/image") -> np.ndarray:
        """The frame logged at ``step``, (H, W) or (H, W, C) (a JPEG frame is decoded with Pillow)."""
        if (entity, "Image:format") not in self._rows or step not in self._rows[(entity, "Image:format")]:
            blob = self._rows.get((entity, "EncodedImage:blob"), {}).get(step)
            if blob is None:
                raise KeyError(f"no frame at step {step} of {entity}")
            try:
                pil: Any = importlib.import_module("PIL.Image")
            except ImportError as e:
                raise ImportError("decoding a JPEG frame needs Pillow: pip install pillow") from e
            data = blob.values[0].values.to_numpy(zero_copy_only=False)
            return np.asarray(pil.open(io.BytesIO(np.ascontiguousarray(data).tobytes())))
        fmt = self._rows[(entity, "Image:format")][step].as_py()[0]
        name = self._rr.ChannelDatatype(fmt["channel_datatype"]).name  # U8, U16, F32, ...
        dtype = np.dtype({"U": "uint", "I": "int", "F": "float"}[name[0]] + name[1:])
        buf = self._rows[(entity, "Image:buffer")][step].values[0].values.to_numpy(zero_copy_only=False)
        image = np.frombuffer(np.ascontiguousarray(buf).tobytes(), dtype=dtype)
        h, w = int(fmt["height"]), int(fmt["width"])
        channels = image.size // (h * w)
        return image.reshape(h, w) if channels == 1 else image.reshape(h, w, channels)

    def __repr__(self) -> str:
        return f"<RecordedRun {str(self.path)!r} {self.bytes} bytes, {len(self.entities)} entities, {len(self.frames)} frames>"


def _check_writable(path: Path) -> None:
    """Raise a clear OSError, creating nothing, when ``path`` cannot be written."""
    if path.is_dir():
        raise IsADirectoryError(f"cannot write the rerun recording {path}: it is a directory")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.exists():
        raise FileNotFoundError(f"cannot write the rerun recording {path}: the directory {parent} does not exist")
    if not parent.is_dir():
        raise NotADirectoryError(f"cannot write the rerun recording {path}: {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write the rerun recording {path}: the directory {parent} is not writable")


def record_servo(
    path: _PathLike,
    scenario: Union[str, Dict[str, Any]] = "ur5e_chessboard",
    steps: int = 100,
    seed: Optional[int] = 0,
    image: bool = True,
    gain: float = 0.3,
    damping: float = 100.0,
    dt_s: float = 0.1,
    stop_px: Optional[float] = None,
    jpeg_quality: Optional[int] = None,
    base_dir: Optional[_PathLike] = None,
    progress: Optional[Callable[[int, int, float], None]] = None,
) -> Dict[str, Any]:
    """Run synthcam's IBVS (``synthcam.servo.ibvs_velocity``) on ``scenario`` and log every step
    to the rerun file ``path`` (see ``Recorder``).

    Each step observes (renders and detects), logs, then commands the IBVS velocity over the
    features detected now and in the goal view (zero when none match) for ``dt_s`` seconds. The
    run takes ``steps`` steps, so the file has ``steps`` frames, unless ``stop_px`` is given: it
    then ends at the first step whose RMS error is below ``stop_px`` px.

    Parameters
    ----------
    path : str or PathLike
        The ``.rrd`` file.
    scenario : str or dict
        A built-in scenario ("ur5e_chessboard", "course") or a scenario file's text or dict.
    steps : int
        Steps to run and log (>= 1).
    seed : int, optional
        Seeds the simulator's image noise (``Sim.reset(seed=...)``).
    image : bool
        Log the frames (``False``: everything but the images, a much smaller file).
    gain, damping, dt_s : float
        The IBVS law's gain, damping (px^2/rad^2) and step (s); see ``synthcam.servo``.
    stop_px : float, optional
        End early below this RMS error (px); ``None`` runs all ``steps``.
    jpeg_quality : int, optional
        See ``Recorder``.
    base_dir : str or PathLike, optional
        Resolves relative paths of a scenario given as text or dict.
    progress : callable, optional
        Called after each step with (steps done, steps, RMS error px).

    Returns
    -------
    dict
        ``path``, ``scenario``, ``steps`` (logged), ``frames`` (steps with an image),
        ``bytes`` (the file's size), ``initial_rms_px``, ``final_rms_px`` (detected vs desired),
        ``wall_s``.
    """
    if int(steps) < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    t0 = time.perf_counter()
    sim = Sim(scenario, base_dir)
    try:
        sim.reset(seed=seed)
        goal = sim.observe_goal()
        if len(goal.ids) == 0:
            raise ValueError(f"the goal view of {sim!r} shows no feature of the target")
        desired = desired_pixels(goal)
        history: List[float] = []
        frames = 0
        with Recorder(path, sim.info, jpeg_quality=jpeg_quality) as rec:
            rec.log_goal(goal)
            for k in range(int(steps)):
                obs = sim.observe(image=image)
                rec.log(k, obs)
                frames += obs.image is not None
                ids, err = matched_error(obs, desired)
                history.append(rms_px(err))
                if progress is not None:
                    progress(k + 1, int(steps), history[-1])
                if stop_px is not None and history[-1] < stop_px:
                    break
                if k == int(steps) - 1:
                    break
                qdot = ibvs_velocity(sim.project, obs.q_rad.tolist(), ids, err, gain, damping, dt_s)
                rec.log_command(k, qdot)
                sim.command(qdot.tolist(), dt_s)
    finally:
        sim.close()
    return {
        "path": str(path),
        "scenario": scenario if isinstance(scenario, str) and "\n" not in scenario else "<custom>",
        "steps": len(history),
        "frames": frames,
        "bytes": os.path.getsize(path),
        "initial_rms_px": history[0],
        "final_rms_px": history[-1],
        "wall_s": round(time.perf_counter() - t0, 3),
    }


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m synthcam.rerun_log",
        description="Run synthcam's IBVS loop and log every step to a rerun .rrd file (open it with `rerun FILE`).",
    )
    parser.add_argument("--scenario", default="ur5e_chessboard", help="a built-in scenario (ur5e_chessboard, course) or a scenario file")
    parser.add_argument("--steps", type=int, default=100, help="steps to run and log (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="the simulator's noise seed (default 0)")
    parser.add_argument("-o", "--output", default="servo.rrd", help="the .rrd file (default servo.rrd)")
    parser.add_argument("--no-image", action="store_true", help="do not log the frames")
    parser.add_argument("--jpeg-quality", type=int, default=None, help="store frames as JPEG of this quality (default: raw)")
    parser.add_argument("--stop-px", type=float, default=None, help="end early below this RMS error, px (default: run all steps)")
    parser.add_argument("--gain", type=float, default=0.3)
    parser.add_argument("--dt", type=float, default=0.1, help="seconds per step (default 0.1)")
    parser.add_argument("--quiet", action="store_true", help="no progress line on stderr")
    args = parser.parse_args(argv)
    scenario, base_dir = args.scenario, None
    if os.path.isfile(args.scenario):
        scenario, base_dir = Path(args.scenario).read_text(), str(Path(args.scenario).resolve().parent)

    def show(done: int, total: int, rms: float) -> None:
        end = "\n" if done == total else ""
        print(f"\rrerun_log: step {done}/{total}, RMS error {rms:.4f} px", end=end, file=sys.stderr, flush=True)

    try:
        summary = record_servo(
            args.output,
            scenario,
            steps=args.steps,
            seed=args.seed,
            image=not args.no_image,
            gain=args.gain,
            dt_s=args.dt,
            stop_px=args.stop_px,
            jpeg_quality=args.jpeg_quality,
            base_dir=base_dir,
            progress=None if args.quiet else show,
        )
    except (OSError, ValueError, ImportError, SynthcamError) as e:  # bad input: a message and exit 1, no traceback
        print(f"\nerror: {e}", file=sys.stderr)
        return 1
    summary["scenario"] = args.scenario
    print(json.dumps(summary))
    return 0


__all__ = ["Desired", "RecordedRun", "Recorder", "record_servo"]

if __name__ == "__main__":
    sys.exit(main())
