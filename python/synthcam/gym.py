"""Gymnasium environments: servo a robot's camera onto a target's goal view, on rendered pixels.

``import synthcam.gym`` registers

- ``synthcam/ServoIBVS-v0``: the "ur5e_chessboard" scenario (UR5e, 6 joints, 48 chessboard corners,
  1920 x 1200 camera);
- ``synthcam/CourseSPath-v0``: the "course" scenario (ABB IRB 1200, 6 joints, the S-path's 101 dots,
  1280 x 1024 camera);

both with ``max_episode_steps=200``; ``ServoEnv(scenario=...)`` takes any other scenario (a built-in
name, or a scenario file's text or dict). Every step renders the camera's view and runs the
detector on it: the observation is what the detector found, not the model's projection.

    import gymnasium as gym
    import synthcam.gym                      # registers the ids (or make("synthcam.gym:synthcam/ServoIBVS-v0"))
    env = gym.make("synthcam/ServoIBVS-v0")  # kwargs: image=True, goal_px=..., render_mode="rgb_array", ...
    policy = synthcam.gym.IbvsPolicy(env)    # the IBVS law of synthcam.servo, as obs -> action
    obs, info = env.reset(seed=0)
    while True:
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated:
            break
    print(info["rms_px"], info["is_success"])

Needs Gymnasium >= 1.0 (``pip install 'synthcam[gym]'``); ``import synthcam`` works without it.
"""

import math
from typing import Any, Dict, Optional, Sequence, SupportsFloat, Tuple, Union

import numpy as np
import numpy.typing as npt

try:
    import gymnasium as gym  # type: ignore[import-not-found, unused-ignore]
    from gymnasium import spaces  # type: ignore[import-not-found, unused-ignore]
except ImportError as _e:  # pragma: no cover - exercised without gymnasium
    raise ImportError(
        "synthcam.gym needs Gymnasium (>= 1.0): pip install 'synthcam[gym]' (or pip install gymnasium)"
    ) from _e

from . import Observation, Sim, SynthcamError
from .servo import ibvs_velocity, rms_px

Obs = Dict[str, np.ndarray]
"""An observation of ``ServoEnv``: a dict of NumPy arrays (see ``ServoEnv``)."""

_Scenario = Union[str, Dict[str, Any]]


class ServoEnv(gym.Env[Dict[str, Any], np.ndarray]):
    """Visual servoing as a Gymnasium environment: move the arm's joints so that the camera on its
    tool sees the target as it does from the scenario's goal pose.

    Observation (a ``spaces.Dict``; every array is fixed-size over all ``N`` features of the target,
    ``N = sim.info["features"]``, indexed by feature id):

    - ``pixels_px`` (N, 2) float32: the pixels (px, OpenCV's convention: the centre of the top-left
      pixel is (0, 0)) the detector found in this step's rendered frame; 0 where not detected.
      Bounds [-1, W] x [-1, H] (W x H the image size; a detection lies within the image, values are
      clipped to the bounds in any case).
    - ``mask`` (N,) int8 (``MultiBinary``): 1 where the feature was detected in this frame.
    - ``desired_px`` (N, 2) float32 and ``desired_mask`` (N,) int8: the features detected in the
      goal view (rendered once when the environment is built; constant), so a policy knows the goal.
    - ``q_rad`` (dof,) float64: the joint positions, rad, within +-``joint_bound_rad``.
    - ``image`` (H, W) uint8 (the scenario's image format): the rendered frame; only with
      ``image=True``.

    Action: joint velocities, rad/s, a ``Box`` of shape (dof,) float32 with bounds
    +-``max_qdot_rad_s`` per joint (default 1 rad/s for every joint: well below the built-in robots'
    limits, the UR5e's pi rad/s and the IRB 1200's 4.2 to 10.5 rad/s, so the simulator never scales
    a command down). An action outside the bounds is clipped to them; it is held for ``dt_s``
    seconds (``q += qdot dt_s``), then the camera's view is rendered and detected.

    Reward, in px (always <= 0): with ``matched`` the features detected both now and in the goal
    view and ``missing`` the goal's features not detected now,

        reward = -(rms + missing_penalty_px * len(missing)),
        rms    = sqrt(mean_{i in matched} |p_i - p*_i|^2)   (the image diagonal when nothing matches).

    A command the arm refuses (a joint would cross its position limit, or leave
    +-``joint_bound_rad``) costs ``limit_penalty_steps`` steps with every goal feature missing:
    ``reward -= limit_penalty_steps * (diagonal + missing_penalty_px * N*)`` (N* the number of goal
    features), so that ending the episode this way is never cheaper than servoing.

    Episode end:

    - ``terminated`` at the goal: ``rms < goal_px`` with at least ``goal_seen_fraction`` of the goal's
      features detected (``info["is_success"]`` is True); or when a command is refused: the arm is
      left where it was (the simulator changes nothing), the step observes it there and returns
      ``terminated=True`` with ``info["refused"] = True`` and the simulator's message in
      ``info["refusal"]``.
    - ``truncated`` at the step limit: the registered ids wrap the environment in Gymnasium's
      ``TimeLimit`` (``max_episode_steps=200``); build one with ``gymnasium.make(...,
      max_episode_steps=...)`` or wrap ``ServoEnv`` yourself.

    A view the renderer cannot draw (the target behind the camera) is observed as nothing
    detected (``mask`` all 0, a black ``image``, the lost reward), ``q_rad`` the commanded joints,
    ``info["frame"] = -1`` and the renderer's message in ``info["note"]``; the episode goes on (the
    arm may turn back).

    ``reset(seed=...)``: joints at the scenario's start plus a uniform perturbation of
    +-``start_noise_rad`` per joint, and the simulator's image noise reseeded, both drawn from
    ``self.np_random``: the same seed replays the same observations, images included.
    ``reset(options={"q_rad": q})`` starts at ``q`` exactly (rad). ``info`` (reset and step):
    ``rms_px`` (inf when nothing matches), ``n_detected``, ``n_matched``, ``n_missing``,
    ``is_success``, ``refused``, ``refusal`` ("" when none), ``time_s``, ``frame`` (the
    simulator's frame number), ``note`` (the detector's note, or None).

    Parameters
    ----------
    scenario : str or dict
        A built-in scenario ("ur5e_chessboard", "course") or a scenario file's text or dict.
    image : bool
        Put the rendered frame in the observation (``"image"``).
    dt_s : float
        Seconds each action is held for.
    goal_px : float
        The RMS error (px) under which the goal is reached.
    goal_seen_fraction : float
        The fraction of the goal's features that must be detected to reach the goal.
    start_noise_rad : float
        Half-width (rad) of the uniform perturbation of every start joint.
    max_qdot_rad_s : float or sequence of float
        The action bounds (rad/s), one for all joints or one per joint.
    missing_penalty_px : float
        Reward penalty (px) per goal feature not detected.
    limit_penalty_steps : float
        A refused command costs this many steps with every goal feature missing.
    joint_bound_rad : float
        The joints' observation bounds (rad); a command that would move a joint past it is
        refused like one past a position limit (it matters for scenarios that ignore joint limits,
        such as "course").
    render_mode : None or "rgb_array"
        ``render()`` then returns the last rendered frame as (H, W, 3) uint8.
    base_dir : str, optional
        Resolves relative paths of a scenario given as text or dict.
    """

    metadata: Dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        scenario: _Scenario = "ur5e_chessboard",
        image: bool = False,
        dt_s: float = 0.1,
        goal_px: float = 0.5,
        goal_seen_fraction: float = 0.95,
        start_noise_rad: float = 0.02,
        max_qdot_rad_s: Union[float, Sequence[float]] = 1.0,
        missing_penalty_px: float = 10.0,
        limit_penalty_steps: float = 100.0,
        joint_bound_rad: float = 4.0 * math.pi,
        render_mode: Optional[str] = None,
        base_dir: Optional[str] = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}")
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s}")
        self.render_mode = render_mode
        self.image = bool(image)
        self.dt_s = float(dt_s)
        self.goal_px = float(goal_px)
        self.goal_seen_fraction = float(goal_seen_fraction)
        self.start_noise_rad = float(start_noise_rad)
        self.missing_penalty_px = float(missing_penalty_px)
        self.limit_penalty_steps = float(limit_penalty_steps)
        self.joint_bound_rad = float(joint_bound_rad)
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.dt_s}

        self.sim = Sim(scenario, base_dir)
        info = self.sim.info
        self.dof = int(self.sim.dof)
        self.n_features = int(info["features"])
        self.width, self.height = int(info["camera"]["width"]), int(info["camera"]["height"])
        self.q_start_rad = np.asarray(info["q_start_rad"], dtype=np.float64)
        self._keep_frame = self.image or render_mode is not None

        goal = self.sim.observe_goal(image=self._keep_frame)
        if len(goal.ids) == 0:
            raise ValueError(f"the goal view of {self.sim!r} shows no feature of the target")
        self._desired_mask = np.zeros(self.n_features, dtype=np.int8)
        self._desired_mask[goal.ids] = 1
        self._desired = np.zeros((self.n_features, 2), dtype=np.float64)
        self._desired[goal.ids] = goal.pixels_px
        self._n_desired = int(len(goal.ids))
        self.diagonal_px = math.hypot(self.width, self.height)
        self._lost_cost = self.diagonal_px + self.missing_penalty_px * self._n_desired

        vmax = np.broadcast_to(np.asarray(max_qdot_rad_s, dtype=np.float32), (self.dof,)).copy()
        if not np.all(vmax > 0) or not np.all(np.isfinite(vmax)):
            raise ValueError(f"max_qdot_rad_s must be positive and finite, got {max_qdot_rad_s}")
        self.max_qdot_rad_s = vmax.astype(np.float64)
        self.action_space = spaces.Box(low=-vmax, high=vmax, shape=(self.dof,), dtype=np.float32)

        self._px_low = np.broadcast_to(np.array([-1.0, -1.0], dtype=np.float32), (self.n_features, 2)).copy()
        self._px_high = np.broadcast_to(np.array([self.width, self.height], dtype=np.float32), (self.n_features, 2)).copy()
        obs_spaces: Dict[str, Any] = {
            "pixels_px": spaces.Box(low=self._px_low, high=self._px_high, dtype=np.float32),
            "mask": spaces.MultiBinary(self.n_features),
            "desired_px": spaces.Box(low=self._px_low, high=self._px_high, dtype=np.float32),
            "desired_mask": spaces.MultiBinary(self.n_features),
            "q_rad": spaces.Box(low=-self.joint_bound_rad, high=self.joint_bound_rad, shape=(self.dof,), dtype=np.float64),
        }
        self._blank = np.zeros_like(np.asarray(goal.image)) if self._keep_frame else np.zeros((0, 0), dtype=np.uint8)
        if self.image:
            frame = np.asarray(goal.image)
            top = np.iinfo(frame.dtype).max if np.issubdtype(frame.dtype, np.integer) else 1.0
            obs_spaces["image"] = spaces.Box(low=0, high=top, shape=frame.shape, dtype=frame.dtype)
        self.observation_space = spaces.Dict(obs_spaces)

        self._q = self.q_start_rad.copy()
        self._q_commanded = self._q.copy()
        self._time_s = 0.0
        self._frame: Optional[np.ndarray] = None
        self._closed = False

    # -- the episode ---------------------------------------------------------------------------

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None) -> Tuple[Obs, Dict[str, Any]]:
        """Start an episode: joints at the scenario's start plus a uniform perturbation of
        +-``start_noise_rad`` (rad) per joint, or at ``options["q_rad"]`` exactly; the simulator's
        image noise reseeded from ``self.np_random`` (seeded by ``seed``), time and frame 0.

        Returns
        -------
        (observation, info)
            See the class docstring. A perturbed start the arm does not admit (outside a joint
            limit) falls back to the scenario's start.
        """
        super().reset(seed=seed)
        noise = self.np_random.uniform(-self.start_noise_rad, self.start_noise_rad, size=self.dof)
        sim_seed = int(self.np_random.integers(0, 2**63 - 1))
        if options is not None and options.get("q_rad") is not None:
            q = np.asarray(options["q_rad"], dtype=np.float64).reshape(-1)
            if q.shape != (self.dof,) or not np.all(np.isfinite(q)):
                raise ValueError(f"options['q_rad'] needs {self.dof} finite joints (rad), got {options['q_rad']!r}")
            if np.any(np.abs(q) > self.joint_bound_rad):
                raise ValueError(f"options['q_rad'] lies outside +-joint_bound_rad = {self.joint_bound_rad}: {q.tolist()}")
            self.sim.reset(q.tolist(), seed=sim_seed)  # raises SynthcamError outside the arm's limits
        else:
            q = self.q_start_rad + noise
            try:
                self.sim.reset(q.tolist(), seed=sim_seed)
            except SynthcamError:
                q = self.q_start_rad.copy()
                self.sim.reset(q.tolist(), seed=sim_seed)
        self._q_commanded, self._time_s = q.copy(), 0.0
        obs, cost, info = self._observe()
        return obs, info

    def step(self, action: np.ndarray) -> Tuple[Obs, SupportsFloat, bool, bool, Dict[str, Any]]:
        """Hold the joint velocities ``action`` (rad/s, clipped to the action bounds) for ``dt_s``
        seconds, then render and detect.

        Returns
        -------
        (observation, reward, terminated, truncated, info)
            ``reward`` (px, <= 0), ``terminated`` at the goal or on a refused command (the arm
            then stays where it was; ``info["refused"]``), ``truncated`` always False here (the
            registered ids add a ``TimeLimit``); see the class docstring.
        """
        qdot = np.asarray(action, dtype=np.float64).reshape(-1)
        if qdot.shape != (self.dof,) or not np.all(np.isfinite(qdot)):
            raise ValueError(f"the action needs {self.dof} finite joint velocities (rad/s), got {action!r}")
        qdot = np.clip(qdot, -self.max_qdot_rad_s, self.max_qdot_rad_s)
        refusal = ""
        ahead = self._q + qdot * self.dt_s
        if np.any(np.abs(ahead) > self.joint_bound_rad):
            refusal = f"joints {ahead.tolist()} would leave +-joint_bound_rad = {self.joint_bound_rad}"
        else:
            try:
                self.sim.command(qdot.tolist(), self.dt_s)
                self._q_commanded, self._time_s = ahead, self._time_s + self.dt_s
            except SynthcamError as e:  # a position limit: the simulator leaves the joints as they were
                refusal = str(e)
        if refusal:
            self._q_commanded = self._q.copy()
        obs, cost, info = self._observe(refusal)
        reward = -cost
        if refusal:
            reward -= self.limit_penalty_steps * self._lost_cost
        terminated = bool(info["is_success"] or info["refused"])
        return obs, float(reward), terminated, False, info

    def render(self) -> Optional[np.ndarray]:
        """The last rendered frame as (H, W, 3) uint8 (``render_mode="rgb_array"``); None before
        the first ``reset`` or without a render mode."""
        if self.render_mode is None:
            gym.logger.warn("ServoEnv.render() without a render_mode: build it with render_mode='rgb_array'")
            return None
        if self._frame is None:
            return None
        frame = self._frame
        if frame.dtype == np.uint16:
            frame = (frame >> 8).astype(np.uint8)
        elif frame.dtype != np.uint8:
            frame = (np.clip(frame, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
        if frame.ndim == 2:
            frame = np.repeat(frame[:, :, None], 3, axis=2)
        return np.ascontiguousarray(frame[:, :, :3])

    def close(self) -> None:
        """Close the simulator (a second call does nothing)."""
        if not self._closed:
            self._closed = True
            self.sim.close()

    # -- helpers -------------------------------------------------------------------------------

    @property
    def desired_px(self) -> npt.NDArray[np.float64]:
        """(N, 2): the goal view's detected pixels (px), 0 where not detected."""
        return self._desired.copy()

    @property
    def desired_mask(self) -> npt.NDArray[np.int8]:
        """(N,): 1 for the features detected in the goal view."""
        return self._desired_mask.copy()

    def feature_error(self, ids: npt.ArrayLike, pixels_px: npt.ArrayLike) -> Tuple[float, int, int]:
        """(rms_px, n_matched, n_missing) of detected features ``ids`` at ``pixels_px`` (px) against
        the goal view; ``rms_px`` is inf when no feature matches."""
        idx = np.asarray(ids, dtype=np.int64).reshape(-1)
        pix = np.asarray(pixels_px, dtype=np.float64).reshape(-1, 2)
        keep = self._desired_mask[idx] == 1
        matched = idx[keep]
        rms = rms_px(pix[keep] - self._desired[matched])
        return rms, int(len(matched)), self._n_desired - int(len(matched))

    def _observe(self, refusal: str = "") -> Tuple[Obs, float, Dict[str, Any]]:
        try:
            o: Optional[Observation] = self.sim.observe(image=self._keep_frame)
            unrendered = ""
        except SynthcamError as e:  # e.g. the target behind the camera: nothing to render
            if "closed" in str(e):
                raise
            o, unrendered = None, str(e)
        if o is not None:
            self._q = np.asarray(o.q_rad, dtype=np.float64).copy()
            self._time_s = float(o.time_s)
            ids = np.asarray(o.ids, dtype=np.int64)
            pixels = np.asarray(o.pixels_px, dtype=np.float64).reshape(-1, 2)
        else:
            self._q = self._q_commanded.copy()
            ids, pixels = np.zeros(0, dtype=np.int64), np.zeros((0, 2))
        obs_px = np.zeros((self.n_features, 2), dtype=np.float32)
        obs_px[ids] = pixels
        mask = np.zeros(self.n_features, dtype=np.int8)
        mask[ids] = 1
        obs: Obs = {
            "pixels_px": np.clip(obs_px, self._px_low, self._px_high),
            "mask": mask,
            "desired_px": np.clip(self._desired.astype(np.float32), self._px_low, self._px_high),
            "desired_mask": self._desired_mask.copy(),
            "q_rad": np.clip(self._q, -self.joint_bound_rad, self.joint_bound_rad),
        }
        if self._keep_frame:
            self._frame = np.asarray(o.image) if o is not None else np.zeros_like(self._blank)
            if self.image:
                obs["image"] = self._frame.copy()
        rms, n_matched, n_missing = self.feature_error(ids, pixels)
        cost = (rms if n_matched else self.diagonal_px) + self.missing_penalty_px * n_missing
        seen_enough = n_matched >= math.ceil(self.goal_seen_fraction * self._n_desired - 1e-9)
        info: Dict[str, Any] = {
            "rms_px": rms,
            "n_detected": int(len(ids)),
            "n_matched": n_matched,
            "n_missing": n_missing,
            "is_success": bool(n_matched > 0 and seen_enough and rms < self.goal_px),
            "refused": bool(refusal),
            "refusal": refusal,
            "time_s": self._time_s,
            "frame": int(o.frame) if o is not None else -1,
            "note": o.note if o is not None else unrendered,
        }
        return obs, float(cost), info

    def __repr__(self) -> str:
        return f"<ServoEnv {self.sim!r} image={self.image} dt_s={self.dt_s}>"


class IbvsPolicy:
    """Image-based visual servoing as a policy of ``ServoEnv``: observation -> action.

    The law of ``synthcam.servo.ibvs_velocity``: over the features detected now and in the goal
    view, ``qdot = -gain (J^T J + damping I)^-1 J^T (s - s*) / dt_s`` with the image Jacobian ``J``
    (px/rad) by central differences of the environment's model (``env.unwrapped.sim.project``, the
    arm's kinematics and the camera: the knowledge a model-based controller has), then scaled down
    as a whole (direction kept) to fit the action bounds. No feature in common: zero velocity.

    Parameters
    ----------
    env : gymnasium.Env
        A ``ServoEnv``, wrapped or not.
    gain : float
        Fraction of the pixel error removed per step.
    damping : float
        Damping of the pseudo-inverse, px^2/rad^2.
    """

    def __init__(self, env: Any, gain: float = 0.3, damping: float = 100.0) -> None:
        base = env.unwrapped
        if not isinstance(base, ServoEnv):
            raise TypeError(f"IbvsPolicy needs a synthcam.gym.ServoEnv, got {type(base).__name__}")
        self.env = base
        self.gain = float(gain)
        self.damping = float(damping)

    def __call__(self, obs: Obs) -> np.ndarray:
        """Joint velocities (rad/s, float32, within the action bounds) for observation ``obs``."""
        env = self.env
        ids = np.flatnonzero((np.asarray(obs["mask"]) == 1) & (np.asarray(obs["desired_mask"]) == 1))
        high = env.max_qdot_rad_s
        if len(ids) == 0:
            return np.zeros(env.dof, dtype=np.float32)
        error = (np.asarray(obs["pixels_px"], dtype=np.float64)[ids] - np.asarray(obs["desired_px"], dtype=np.float64)[ids]).reshape(-1)
        qdot = ibvs_velocity(env.sim.project, np.asarray(obs["q_rad"], dtype=np.float64).tolist(), ids, error, self.gain, self.damping, env.dt_s)
        with np.errstate(divide="ignore"):
            room = np.where(qdot != 0, high / np.abs(qdot), np.inf)
        scale = min(1.0, float(room.min()))
        return np.clip(qdot * scale, -high, high).astype(np.float32)


def _register() -> None:
    for env_id, scenario in (("synthcam/ServoIBVS-v0", "ur5e_chessboard"), ("synthcam/CourseSPath-v0", "course")):
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="synthcam.gym:ServoEnv", max_episode_steps=200, kwargs={"scenario": scenario})


_register()

__all__ = ["IbvsPolicy", "Obs", "ServoEnv"]
