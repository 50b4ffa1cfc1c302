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


def test_the_installed_wheel_is_what_runs():
    """CI (`SYNTHCAM_WHEEL_TEST=1`) runs these tests against the wheel installed in a fresh
    virtualenv: the package must come from site-packages, not from this repository's python/."""
    import os
    from pathlib import Path

    if os.environ.get("SYNTHCAM_WHEEL_TEST") != "1":
        pytest.skip("skipped: set SYNTHCAM_WHEEL_TEST=1 when testing an installed wheel")
    import synthcam
    from synthcam import _synthcam

    repo_python = Path(__file__).resolve().parents[1]
    for module in (synthcam, _synthcam):
        where = Path(module.__file__).resolve()
        assert "site-packages" in where.parts and repo_python not in where.parents, where
