"""A Python controller closes an image-based visual servoing loop on rendered, detected pixels.

The law is the simplest IBVS one (Chaumette & Hutchinson 2006, eq. 3), qdot = -gain J^+ (s - s*),
with the image Jacobian d(pixel)/d(q) taken by central differences of the simulator's model
(`Sim.project`) and a damped pseudo-inverse, all in NumPy (`synthcam.servo`, the same law that
`synthcam.gym.IbvsPolicy` runs as a Gymnasium policy). The desired features are taught by
showing the camera the goal view. Exits non-zero unless the loop ends below 0.5 px RMS.

    python python/examples/ibvs.py
"""

import sys

import synthcam
from synthcam.servo import desired_pixels, ibvs_velocity, matched_error, rms_px


def servo(sim, steps=200, gain=0.3, damping=100.0, dt_s=0.1, stop_px=0.05):
    """Run the loop; returns the list of RMS errors, one per step."""
    desired = desired_pixels(sim.observe_goal())
    history = []
    for _ in range(steps):
        obs = sim.observe()
        ids, e = matched_error(obs, desired)
        history.append(rms_px(e))
        if history[-1] < stop_px or not ids:
            break
        # image Jacobian by central differences of sim.project, damped least squares, gain
        qdot = ibvs_velocity(sim.project, obs.q_rad, ids, e, gain=gain, damping=damping, dt_s=dt_s)
        sim.command(qdot.tolist(), dt_s)
    return history


if __name__ == "__main__":
    sim = synthcam.Sim("ur5e_chessboard")
    history = servo(sim)
    print(f"{sim!r}: {len(history)} steps, {history[0]:.2f} px -> {history[-1]:.4f} px RMS")
    sys.exit(0 if history[-1] <= 0.5 else 1)
