"""A Python controller closes an image-based visual servoing loop on rendered, detected pixels.

The law is the simplest IBVS one (Chaumette & Hutchinson 2006, eq. 3), qdot = -gain J^+ (s - s*),
with the image Jacobian d(pixel)/d(q) taken by central differences of the simulator's model
(`Sim.project`) and a damped pseudo-inverse, all in NumPy. The desired features are taught by
showing the camera the goal view. Exits non-zero unless the loop ends below 0.5 px RMS.

    python python/examples/ibvs.py
"""

import sys

import numpy as np

import synthcam


def rms_error(obs, desired):
    """RMS distance (px) of the detected features to their desired pixels, and the stacked error."""
    rows = [(i, p - desired[i]) for i, p in zip(obs["ids"], obs["pixels_px"]) if i in desired]
    ids = [i for i, _ in rows]
    e = np.concatenate([d for _, d in rows]) if rows else np.zeros(0)
    return (np.sqrt(np.mean(e.reshape(-1, 2) ** 2) * 2) if rows else np.inf), ids, e


def image_jacobian(sim, q, ids, eps=1e-6):
    """d(pixel)/d(q) of the features `ids` at joints `q`, central differences of the model."""
    jac = np.zeros((2 * len(ids), len(q)))
    for k in range(len(q)):
        qp, qm = np.array(q, float), np.array(q, float)
        qp[k] += eps
        qm[k] -= eps
        d = (sim.project(qp.tolist())[ids] - sim.project(qm.tolist())[ids]) / (2 * eps)
        jac[:, k] = d.reshape(-1)
    return jac


def servo(sim, steps=200, gain=0.3, damping=100.0, dt_s=0.1, stop_px=0.05):
    """Run the loop; returns the list of RMS errors, one per step."""
    goal = sim.observe_goal()
    desired = dict(zip(goal["ids"], goal["pixels_px"]))
    history = []
    for _ in range(steps):
        obs = sim.observe()
        rms, ids, e = rms_error(obs, desired)
        history.append(rms)
        if rms < stop_px or not ids:
            break
        jac = image_jacobian(sim, obs["q_rad"], ids)
        dq = np.linalg.solve(jac.T @ jac + damping * np.eye(sim.dof), jac.T @ e)
        sim.command((-gain * dq / dt_s).tolist(), dt_s)
    return history


if __name__ == "__main__":
    sim = synthcam.Sim("ur5e_chessboard")
    history = servo(sim)
    print(f"{sim!r}: {len(history)} steps, {history[0]:.2f} px -> {history[-1]:.4f} px RMS")
    sys.exit(0 if history[-1] <= 0.5 else 1)
