"""The README's Python examples run as written and meet the issue's bounds."""

import re
import subprocess
import sys

import pytest


def run_example(root, name):
    r = subprocess.run([sys.executable, str(root / "python" / "examples" / name)], cwd=root, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_quickstart_corner_error_within_0_015_px(root):
    out = run_example(root, "quickstart.py")
    rms = float(re.search(r"RMS error vs truth ([0-9.]+) px", out).group(1))
    print(out.strip())
    assert rms <= 0.015


def test_ibvs_example_converges_below_0_5_px(root):
    out = run_example(root, "ibvs.py")
    final = float(re.search(r"-> ([0-9.]+) px RMS", out).group(1))
    print(out.strip())
    assert final <= 0.5


def test_stereo_rig_example_meets_the_rig_bounds(root):
    out = run_example(root, "stereo_rig.py")
    print(out.strip())
    dt_mm = float(re.search(r"baseline error ([0-9.]+) mm", out).group(1))
    dr = float(re.search(r"rotation error ([0-9.]+) deg", out).group(1))
    rows = float(re.search(r"rectified rows mean ([0-9.]+) px", out).group(1))
    assert dt_mm <= 0.05 and dr <= 0.002 and rows <= 0.02


def test_gym_policies_example_runs_both_policies_and_ibvs_converges(root):
    pytest.importorskip("gymnasium", reason="skipped: gymnasium is not installed (pip install 'synthcam[gym]')")
    out = run_example(root, "gym_policies.py")
    print(out.strip())
    rates = [float(r) for r in re.findall(r"([0-9.]+) steps/s", out)]
    assert len(rates) == 3 and min(rates) > 0.0
    start, final = (float(v) for v in re.search(r"RMS error ([0-9.]+) px -> ([0-9.]+) px", out).groups())
    assert final <= 0.5 and final <= start / 100.0
