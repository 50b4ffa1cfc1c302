"""Two policies through one Gymnasium interface: a random one and synthcam's IBVS law.

Trains nothing. `synthcam.gym` registers the environments; a random policy (uniform joint
velocities within the action bounds) runs 100 steps without and then with images in the
observation, and `IbvsPolicy` (image Jacobian by central differences of the model, damped least
squares, gain 0.3: the law of python/examples/ibvs.py) runs 100 steps as one episode (goal_px=0:
the episode does not stop at the goal, so the error after 100 steps shows where the law settles).
Prints steps per second of each run (rendering and detection included; resets included for the
random runs) and the IBVS error; exits non-zero unless IBVS cuts the RMS pixel error at least
100-fold and ends below 0.5 px.

    pip install 'synthcam[gym]'     # or: pip install gymnasium
    python python/examples/gym_policies.py [ENV_ID]   # default synthcam/ServoIBVS-v0
"""

import sys
import time

import gymnasium as gym

import synthcam.gym  # noqa: F401  (registers synthcam/ServoIBVS-v0 and synthcam/CourseSPath-v0)
from synthcam.gym import IbvsPolicy

STEPS = 100


def run(env, policy, steps=STEPS, seed=0):
    """Run ``policy`` (obs -> action) for ``steps`` steps, resetting whenever an episode ends.
    Returns (steps per second, the info of the reset and of every step, episodes ended)."""
    obs, info = env.reset(seed=seed)
    infos, ended = [info], 0
    t0 = time.perf_counter()
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        infos.append(info)
        if terminated or truncated:
            ended += 1
            obs, info = env.reset()
    return steps / (time.perf_counter() - t0), infos, ended


def main(env_id):
    env = gym.make(env_id)
    env.action_space.seed(0)
    rate, _, ended = run(env, lambda obs: env.action_space.sample())
    print(f"{env_id}: random policy, {STEPS} steps without images: {rate:.1f} steps/s ({ended} episodes ended)")
    env.close()

    env = gym.make(env_id, image=True)
    env.action_space.seed(0)
    rate, _, ended = run(env, lambda obs: env.action_space.sample())
    shape = env.observation_space["image"].shape
    print(f"{env_id}: random policy, {STEPS} steps with {shape[1]} x {shape[0]} images: {rate:.1f} steps/s ({ended} episodes ended)")
    env.close()

    env = gym.make(env_id, goal_px=0.0)
    policy = IbvsPolicy(env)
    rate, infos, ended = run(env, policy)
    errors = [i["rms_px"] for i in infos]
    first = next((k for k, e in enumerate(errors) if e < 0.5), None)
    print(
        f"{env_id}: IBVS policy, {STEPS} steps: {rate:.1f} steps/s, RMS error {errors[0]:.2f} px -> {errors[-1]:.4f} px "
        f"(below 0.5 px from step {first}; {ended} episodes ended)"
    )
    env.close()
    return 0 if ended == 0 and errors[-1] <= errors[0] / 100.0 and errors[-1] <= 0.5 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "synthcam/ServoIBVS-v0"))
