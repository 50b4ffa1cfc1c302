"""synthcam.Sim from Python: a NumPy IBVS law closes the loop on rendered, detected pixels."""

import sys
from pathlib import Path

import numpy as np
import pytest

import synthcam

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import ibvs  # noqa: E402  (python/examples/ibvs.py: the law, written as a user would)


def test_python_ibvs_converges_below_0_5_px():
    sim = synthcam.Sim("ur5e_chessboard")
    history = ibvs.servo(sim)
    print(f"{sim!r}: {len(history)} steps, {history[0]:.2f} px -> {history[-1]:.4f} px RMS")
    assert history[0] > 50.0  # it starts far away
    assert history[-1] <= 0.5
    # The detected features agree with the truth at the end (the loop ran on real pixels).
    obs = sim.observe()
    err = obs["pixels_px"] - obs["truth_px"][obs["ids"]]
    assert np.sqrt((err**2).sum(axis=1).mean()) < 0.05


def test_observation_and_model():
    sim = synthcam.Sim()
    info = sim.info
    assert info["robot"] == "ur5e" and sim.dof == 6 and info["features"] == 48
    obs = sim.observe(image=True)
    assert obs["image"].shape == (info["camera"]["height"], info["camera"]["width"])
    assert obs["pixels_px"].shape == (len(obs["ids"]), 2)
    # The model's prediction at the current joints is the truth of the observation.
    np.testing.assert_allclose(sim.project(obs["q_rad"]), obs["truth_px"], atol=1e-9)
    sim.command([0.01] * 6, 0.1)
    assert sim.observe()["time_s"] == pytest.approx(0.1)
    # typed: the same observation as attributes, the poses as Pose
    typed = sim.observe()
    assert isinstance(typed, synthcam.Observation) and isinstance(typed.cam_from_target, synthcam.Pose)
    assert typed.pixels_px.shape == (len(typed.ids), 2) and typed.q_rad.shape == (6,)
    assert np.sqrt(((typed.pixels_px - typed.truth_px[typed.ids]) ** 2).sum(axis=1).mean()) < 0.05
    # world_from_cam and cam_from_target compose to a fixed world_from_target as the arm moves
    sim.command([0.02, -0.01, 0.01, 0.0, 0.01, 0.0], 0.1)
    moved = sim.observe()
    a, b = typed.world_from_cam @ typed.cam_from_target, moved.world_from_cam @ moved.cam_from_target
    assert np.abs(a.matrix() - b.matrix()).max() < 1e-9
    assert np.abs(typed.world_from_cam.matrix() - moved.world_from_cam.matrix()).max() > 1e-4


def test_sim_bad_input():
    with pytest.raises(synthcam.SynthcamError, match="scenario"):
        synthcam.Sim("[robot]\nkind = 'hexapod'\n")
    sim = synthcam.Sim()
    with pytest.raises(synthcam.SynthcamError, match="6 finite joint velocities"):
        sim.command([0.1, 0.2], 0.1)
    with pytest.raises(synthcam.SynthcamError, match="dt_s"):
        sim.command([0.0] * 6, -1.0)
    sim.close()
    with pytest.raises(synthcam.SynthcamError, match="closed"):
        sim.observe()
