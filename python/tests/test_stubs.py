"""The typed stubs (python/synthcam/_synthcam.pyi) match the extension module (mypy's stubtest)."""

import subprocess
import sys

import pytest


def test_stubs_match_the_extension():
    pytest.importorskip("mypy", reason="skipped: mypy is not installed (pip install mypy)")
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "synthcam._synthcam"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_typed_results_type_check():
    pytest.importorskip("mypy", reason="skipped: mypy is not installed (pip install mypy)")
    import pathlib

    package = pathlib.Path(__file__).resolve().parents[1] / "synthcam"
    r = subprocess.run([sys.executable, "-m", "mypy", str(package)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
