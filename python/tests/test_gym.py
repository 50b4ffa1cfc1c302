"""synthcam.gym: Gymnasium environments over synthcam.Sim (check_env on two scenarios, seeded
resets, refused commands, a random policy and the IBVS policy through the same interface).

About 300 rendered frames in all; skipped when Gymnasium is not installed."""

import math
import subprocess
import sys
import warnings

import numpy as np
import pytest

import synthcam

IDS = {"ur5e_chessboard": "synthcam/ServoIBVS-v0", "course": "synthcam/CourseSPath-v0"}


@pytest.fixture(scope="module")
def gym():
    gymnasium = pytest.importorskip("gymnasium", reason="skipped: gymnasium is not installed (pip install 'synthcam[gym]')")
    import synthcam.gym  # noqa: F401  (registers the ids)

    return gymnasium


def assert_same(a, b):
    """Two observations (dicts of arrays) are identical, key for key, bit for bit."""
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype, k
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


@pytest.mark.parametrize("scenario", sorted(IDS))
def test_check_env_passes_without_warnings(gym, scenario):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(IDS[scenario], image=True, render_mode="rgb_array")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=False)
    assert not [str(w.message) for w in caught if issubclass(w.category, UserWarning)]
    base = env.unwrapped
    info = base.sim.info
    assert env.spec.id == IDS[scenario] and env.spec.max_episode_steps == 200
    n, w, h = info["features"], info["camera"]["width"], info["camera"]["height"]
    space = env.observation_space
    assert space["pixels_px"].shape == (n, 2) and space["mask"].shape == (n,) and space["q_rad"].shape == (base.dof,)
    assert space["image"].shape == (h, w) and space["image"].dtype == np.uint8
    assert env.action_space.shape == (base.dof,) and np.all(env.action_space.high == 1.0)
    obs, _ = env.reset(seed=3)
    assert obs in space and obs["desired_mask"].sum() > 0
    frame = env.render()
    assert frame.shape == (h, w, 3) and frame.dtype == np.uint8
    np.testing.assert_array_equal(frame[:, :, 0], obs["image"])
    env.close()
    env.close()  # a second close is allowed


def test_seeded_reset_replays_the_same_observations(gym):
    actions = np.random.default_rng(0).uniform(-0.3, 0.3, size=(3, 6)).astype(np.float32)

    def episode(env, seed):
        obs, info = env.reset(seed=seed)
        out = [(obs, 0.0, info)]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            out.append((obs, reward, info))
        return out

    env = gym.make("synthcam/ServoIBVS-v0", image=True)
    first, again = episode(env, 7), episode(env, 7)
    other = gym.make("synthcam/ServoIBVS-v0", image=True)
    fresh = episode(other, 7)
    for run in (again, fresh):
        for (o1, r1, i1), (o2, r2, i2) in zip(first, run):
            assert_same(o1, o2)
            assert r1 == r2 and i1 == i2
    assert first[0][0]["image"].shape == (1200, 1920) and first[0][0]["mask"].sum() == 48
    # the noise is drawn afresh every frame: two frames at the same joints differ
    assert not np.array_equal(first[0][0]["image"], first[1][0]["image"])
    # another seed: another start (joints) and other noise
    obs, _ = env.reset(seed=8)
    assert not np.array_equal(obs["q_rad"], first[0][0]["q_rad"])
    start = np.array(env.unwrapped.sim.info["q_start_rad"])
    assert np.abs(obs["q_rad"] - start).max() <= env.unwrapped.start_noise_rad
    env.close()
    other.close()


def test_refused_command_ends_the_episode_and_leaves_the_arm(gym):
    env = gym.make("synthcam/ServoIBVS-v0")
    base = env.unwrapped
    q = np.array(base.sim.info["q_start_rad"])
    q[5] = 2 * math.pi - 0.05  # the UR5e's wrist 3 limit is 2 pi: +1 rad/s for 0.1 s crosses it
    obs, info = env.reset(seed=0, options={"q_rad": q})
    assert not info["refused"]
    obs, reward, terminated, truncated, info = env.step(np.array([0, 0, 0, 0, 0, 1.0], dtype=np.float32))
    assert terminated and not truncated and info["refused"] and not info["is_success"]
    assert "joint 5" in info["refusal"] and "outside" in info["refusal"], info["refusal"]
    np.testing.assert_array_equal(obs["q_rad"], q)  # the arm stayed where it was
    assert obs in env.observation_space
    assert reward <= -base.limit_penalty_steps * base.diagonal_px
    # the env goes on: a new episode starts cleanly
    obs, info = env.reset()
    obs, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
    assert not info["refused"] and not terminated and obs["mask"].sum() == 48
    with pytest.raises(ValueError, match="6 finite joint velocities"):
        env.step(np.array([np.nan] * 6))
    env.close()
    # the course ignores joint limits: the env's bound (+-joint_bound_rad) refuses instead
    env = gym.make("synthcam/CourseSPath-v0")
    bound = env.unwrapped.joint_bound_rad
    q = np.array(env.unwrapped.sim.info["q_start_rad"])
    q[0] = bound - 0.05
    env.reset(seed=0, options={"q_rad": q})
    obs, reward, terminated, truncated, info = env.step(np.array([1.0, 0, 0, 0, 0, 0], dtype=np.float32))
    assert terminated and info["refused"] and "joint_bound_rad" in info["refusal"]
    np.testing.assert_array_equal(obs["q_rad"], q)
    with pytest.raises(ValueError, match="joint_bound_rad"):
        env.reset(options={"q_rad": q + 1.0})
    env.close()


def test_a_view_that_cannot_be_rendered_is_observed_as_nothing_seen(gym):
    env = gym.make("synthcam/ServoIBVS-v0", image=True)
    q = np.array(env.unwrapped.sim.info["q_start_rad"])
    q[3] += math.pi / 2  # wrist 1 turns the camera away: the board lies behind it
    obs, info = env.reset(seed=0, options={"q_rad": q})
    assert obs in env.observation_space and obs["mask"].sum() == 0 and not obs["image"].any()
    assert info["frame"] == -1 and "behind" in info["note"]
    obs, reward, terminated, truncated, info = env.step(np.array([0, 0, 0, -0.5, 0, 0], dtype=np.float32))
    assert not terminated and reward == pytest.approx(-(env.unwrapped.diagonal_px + 10.0 * 48))
    np.testing.assert_allclose(obs["q_rad"], q + [0, 0, 0, -0.05, 0, 0], atol=1e-12)
    env.close()


def test_random_policy_100_steps(gym):
    env = gym.make("synthcam/ServoIBVS-v0", image=True, render_mode="rgb_array")
    env.action_space.seed(1)
    obs, info = env.reset(seed=1)
    episodes, seen = 0, set()
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        assert obs in env.observation_space
        assert np.isfinite(reward) and reward <= 0.0
        seen.add(int(obs["mask"].sum()))
        if terminated or truncated:
            episodes += 1
            obs, info = env.reset()
    assert env.render().shape == (1200, 1920, 3)
    print(f"random policy: {episodes} episodes ended, features seen per step {sorted(seen)}")
    env.close()


def test_ibvs_policy_reaches_the_goal_and_settles(gym):
    from synthcam.gym import IbvsPolicy

    # UR5e, default goal (0.5 px RMS with every corner seen): the episode terminates there
    env = gym.make("synthcam/ServoIBVS-v0")
    policy = IbvsPolicy(env)
    obs, info = env.reset(seed=2)
    start = info["rms_px"]
    for step in range(1, 61):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        assert np.all(np.abs(policy(obs)) <= 1.0)
        if terminated:
            break
    assert terminated and info["is_success"] and not info["refused"] and info["rms_px"] < 0.5
    print(f"ServoIBVS-v0: IBVS {start:.1f} px -> {info['rms_px']:.3f} px RMS, goal in {step} steps")
    env.close()
    # the course, goal_px=0 (no early end): 100 steps of IBVS, the error falls below 0.1 px
    env = gym.make("synthcam/CourseSPath-v0", goal_px=0.0)
    policy = IbvsPolicy(env)
    obs, info = env.reset(seed=2)
    errors = [info["rms_px"]]
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        assert obs in env.observation_space and not terminated and not truncated
        errors.append(info["rms_px"])
    print(f"CourseSPath-v0: IBVS 100 steps, {errors[0]:.1f} px -> {errors[-1]:.4f} px RMS")
    assert errors[0] > 50.0 and errors[-1] < 0.1 and info["n_missing"] == 0
    assert reward == pytest.approx(-errors[-1])
    env.close()


def test_time_limit_truncates(gym):
    env = gym.make("synthcam/CourseSPath-v0", max_episode_steps=2)
    env.reset(seed=0)
    assert env.step(np.zeros(6, dtype=np.float32))[3] is False
    assert env.step(np.zeros(6, dtype=np.float32))[3] is True
    env.close()
    assert gym.make("synthcam.gym:synthcam/ServoIBVS-v0").spec.max_episode_steps == 200


def test_without_gymnasium_synthcam_imports_and_gym_says_what_to_install():
    code = (
        "import sys; sys.modules['gymnasium'] = None\n"
        "import synthcam, synthcam.servo\n"
        "try:\n    import synthcam.gym\nexcept ImportError as e:\n    print('ImportError:', e)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "ImportError: synthcam.gym needs Gymnasium" in r.stdout and "pip install 'synthcam[gym]'" in r.stdout
    assert hasattr(synthcam, "Sim")
