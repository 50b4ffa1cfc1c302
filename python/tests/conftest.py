"""Shared fixtures: the repository root, the `synthcam` CLI binary, the example scene."""

import os
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def synthcam_bin() -> str:
    """The CLI binary: $SYNTHCAM_BIN, target/release/synthcam, or `synthcam` on PATH."""
    for candidate in (os.environ.get("SYNTHCAM_BIN"), str(ROOT / "target" / "release" / "synthcam"), shutil.which("synthcam")):
        if candidate and os.path.exists(candidate):
            return candidate
    pytest.skip("skipped: no synthcam binary (build it with `cargo build --release` or set SYNTHCAM_BIN)")


@pytest.fixture(scope="session")
def board_scene_text() -> str:
    """A 12 x 9-square chessboard under barrel distortion k1 = -0.25 (assets/scenes/chessboard_k1.toml)."""
    return (ROOT / "assets" / "scenes" / "chessboard_k1.toml").read_text()
