"""synthcam.Dataset over a folder written by the CLI: every image with its truth."""

import subprocess

import numpy as np
import pytest

import synthcam


@pytest.fixture(scope="module")
def dataset_dir(tmp_path_factory, root, synthcam_bin):
    spec = (root / "assets" / "specs" / "tiny.toml").read_text().replace("count = 200", "count = 6")
    folder = tmp_path_factory.mktemp("ds")
    (folder / "spec.toml").write_text(spec)
    out = folder / "out"
    subprocess.run([synthcam_bin, "dataset", str(folder / "spec.toml"), "-o", str(out), "--shard", "0/2"], check=True)
    subprocess.run([synthcam_bin, "dataset", str(folder / "spec.toml"), "-o", str(out), "--shard", "1/2"], check=True)
    return out


def test_dataset_yields_every_image_with_its_truth(dataset_dir):
    ds = synthcam.Dataset(dataset_dir)  # two shard manifests, not merged
    assert len(ds) == 6
    errors = []
    for k, (image, truth, entry) in enumerate(ds):
        assert entry["k"] == k
        assert image.shape == (truth["camera"]["height"], truth["camera"]["width"]) == (240, 320)
        found = synthcam.detect(image, "chessboard:6x4")
        truth_px = np.array([f["pixel_px"] for f in truth["features"]])
        assert isinstance(truth, synthcam.Truth) and np.array_equal(truth.pixels_px, truth_px)
        if found["found"]:
            errors.append(np.sqrt(((found["points_px"] - truth_px) ** 2).sum(axis=1).mean()))
    print(f"{len(errors)} of 6 found, corner RMS vs truth max {max(errors):.4f} px")
    assert len(errors) >= 5 and max(errors) < 0.1


def test_dataset_errors(tmp_path):
    with pytest.raises(synthcam.SynthcamError, match="manifest"):
        synthcam.Dataset(tmp_path)
    (tmp_path / "manifest.jsonl").write_text('{"k": 0, "file": "images/000000.png", "truth": "images/000000.json"}\n')
    ds = synthcam.Dataset(tmp_path)
    with pytest.raises(synthcam.SynthcamError, match="cannot read"):
        ds[0]


def test_a_rig_dataset_reads_per_camera_and_calibrates_as_a_rig(tmp_path, root, synthcam_bin):
    """`[[cameras]]` spec: Dataset(path, camera=name) reads that camera's images and truth; the
    frames' detections calibrate the rig to the spec's baseline (12 cm, 2 degrees of toe-in)."""
    spec = (root / "assets" / "specs" / "stereo_rig_1280.toml").read_text().replace("count = 20", "count = 12")
    (tmp_path / "spec.toml").write_text(spec)
    out = tmp_path / "out"
    subprocess.run([synthcam_bin, "dataset", str(tmp_path / "spec.toml"), "-o", str(out)], check=True)
    cams = []
    for name in ("left", "right"):
        ds = synthcam.Dataset(out, camera=name)
        assert len(ds) == 12 and ds.entries[0]["file"] == f"images/{name}/000000.png"
        cams.append({"name": name, "image_size": (1280, 1024), "detections": [synthcam.detect(image, "chessboard:8x6") for image, _, _ in ds]})
    left, right = synthcam.Dataset(out, camera="left")[0], synthcam.Dataset(out, camera="right")[0]
    assert left.truth.cam_from_target.t_m[0] - right.truth.cam_from_target.t_m[0] == pytest.approx(0.12, abs=0.03)
    rig = synthcam.calibrate_rig(cams, "chessboard:8x6", 0.03)
    t = rig.cameras[1].cam0_from_cam.t_m
    print(f"rig from the dataset: t {t}, rms {rig.rms_px:.4f} px")
    assert np.linalg.norm(t - [0.12, 0.0, 0.0]) < 5e-5 and rig.rectified_row_error_mean_px < 0.02
    with pytest.raises(synthcam.SynthcamError, match="no camera 'middle'"):
        synthcam.Dataset(out, camera="middle")
