#!/usr/bin/env python3
"""Issue 40: are the rig's extrinsic sigmas honest? Coverage over independent rendered data sets.

Usage (from the repository root, after `cargo build --release`):
    python3 benches/rig_coverage.py [--sets 20] [--seed 7000] [--spec assets/specs/stereo_rig_1280.toml]

Each set: the spec (a `[[cameras]]` rig dataset; default issue 40's stereo pair, 12 cm, 2 degrees
toe-in, 20 frames, noise 1) rendered with seed `--seed + i` by `synthcam dataset`, the corners
detected and the rig calibrated by `synthcam calibrate --rig` (`--model`, default opencv5; the
mixed rig: `--spec assets/specs/mixed_rig_1280.toml --model fisheye,opencv4`). For every
camera after the first, each of the 6 extrinsic components (cam0_from_cam's translation x y z
and rotation vector x y z) is compared with the spec's truth and divided by its reported sigma:
the share of |error| / sigma within 1 and 2 (a Gaussian: 68.3 % and 95.4 %). Also the worst
translation and rotation errors, and every camera's fx fy cx cy error from the rig beside the
same camera calibrated alone (`synthcam calibrate` on its folder). Renders include the detector's own bias, which the sigmas
(from the fit's residuals) do not model.
"""
import argparse, json, os, re, subprocess, sys, tempfile

import numpy as np


def rvec_of(R):
    c = np.clip((np.trace(R) - 1) / 2, -1, 1)
    th = np.arccos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return 0.5 * w if th < 1e-9 else th * w / (2 * np.sin(th))


def rot_of(rvec):
    th = np.linalg.norm(rvec)
    if th < 1e-15:
        return np.eye(3)
    k = np.asarray(rvec) / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def truth_from_spec(text):
    """cam0_from_cam of each camera from the spec's rig_from_cam entries (rvec form)."""
    poses = []
    for m in re.finditer(r"name = \"([^\"]+)\"[\s\S]*?rig_from_cam = \{ rvec = \[([^\]]+)\], t_m = \[([^\]]+)\] \}", text):
        rv = np.array([float(v) for v in m.group(2).split(",")])
        t = np.array([float(v) for v in m.group(3).split(",")])
        poses.append((m.group(1), rot_of(rv), t))
    (_, R0, t0) = poses[0]
    out = []
    for name, R, t in poses:  # cam0_from_cam = (rig_from_cam0)^-1 rig_from_cam
        out.append((name, R0.T @ R, R0.T @ (t - t0)))
    return out


def intrinsics_from_spec(text):
    """Each camera's (fx, fy, cx, cy) from its [[cameras]] table."""
    out = []
    for block in re.split(r"(?m)^\[\[cameras\]\]", text)[1:]:
        block = block.split("\n[")[0]
        out.append(np.array([float(re.search(rf"(?m)^{k} = ([-0-9.e]+)", block).group(1)) for k in ("fx", "fy", "cx", "cy")]))
    return out


def k_of(c):
    K = np.asarray(c["K"])
    return np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", type=int, default=20)
    ap.add_argument("--seed", type=int, default=7000)
    ap.add_argument("--spec", default="assets/specs/stereo_rig_1280.toml")
    ap.add_argument("--synthcam", default="target/release/synthcam")
    ap.add_argument("--target", default="chessboard:8x6")
    ap.add_argument("--square", default="0.03")
    ap.add_argument("--model", default="opencv5", help="one model, or one per camera: fisheye,opencv4")
    a = ap.parse_args()
    text = open(a.spec).read()
    truth = truth_from_spec(text)
    k_truth = intrinsics_from_spec(text)
    models = a.model.split(",") * (len(truth) if "," not in a.model else 1)
    z, worst_t, worst_r = [], 0.0, 0.0
    k_err = {"rig": [], "single": []}
    env = dict(os.environ, NODEVICE_SELECT="1")
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(a.sets):
            spec = os.path.join(tmp, f"spec{i}.toml")
            open(spec, "w").write(re.sub(r"(?m)^seed = \d+", f"seed = {a.seed + i}", text))
            ds = os.path.join(tmp, f"ds{i}")
            subprocess.run([a.synthcam, "dataset", spec, "-o", ds], check=True, capture_output=True, env=env)
            out = os.path.join(tmp, f"rig{i}.json")
            dirs = [os.path.join(ds, "images", name) for name, _, _ in truth]
            r = subprocess.run([a.synthcam, "calibrate", "--rig", *dirs, "--target", a.target, "--square", a.square, "--model", a.model, "--json", out], capture_output=True, text=True, env=env)
            if r.returncode != 0:
                print(f"set {i}: calibrate failed: {r.stderr.strip().splitlines()[-1:]}")
                continue
            j = json.load(open(out))
            for ci, (d, c) in enumerate(zip(dirs, j["cameras"])):
                single = os.path.join(tmp, f"single{i}_{ci}.json")
                subprocess.run([a.synthcam, "calibrate", d, "--target", a.target, "--square", a.square, "--model", models[ci], "--json", single], check=True, capture_output=True, env=env)
                k_err["single"].append(np.abs(k_of(json.load(open(single))) - k_truth[ci]))
                k_err["rig"].append(np.abs(k_of(c) - k_truth[ci]))
            for (name, R, t), c in list(zip(truth, j["cameras"]))[1:]:
                R_est = np.asarray(c["cam0_from_cam"]["R"])
                t_est = np.asarray(c["cam0_from_cam"]["t_m"])
                dt = t_est - t
                dr = np.degrees(rvec_of(R_est) - rvec_of(R))
                z += list(dt / np.asarray(c["translation_std_m"])) + list(dr / np.asarray(c["rotation_std_deg"]))
                worst_t = max(worst_t, np.linalg.norm(dt) * 1e3)
                worst_r = max(worst_r, np.degrees(np.linalg.norm(rvec_of(R_est.T @ R))))
                print(f"set {i} {name}: |dt| {np.linalg.norm(dt) * 1e3:.4f} mm, |dr| {np.degrees(np.linalg.norm(rvec_of(R_est.T @ R))):.5f} deg, rms {j['rms_px']:.4f} px")
    for kind, e in k_err.items():
        e = np.asarray(e)
        print(f"intrinsics, {kind:6s} calibration: |error| fx fy cx cy RMS {np.sqrt((e ** 2).mean(0)).round(4).tolist()} px, max {e.max(0).round(4).tolist()} px")
    z = np.abs(np.asarray(z))
    print(f"{len(z)} extrinsic components over {a.sets} sets (seeds {a.seed}-{a.seed + a.sets - 1}): within 1 sigma {100 * np.mean(z <= 1):.1f} %, within 2 sigma {100 * np.mean(z <= 2):.1f} % "
          f"(Gaussian 68.3 / 95.4); worst translation error {worst_t:.4f} mm, rotation {worst_r:.5f} deg")


if __name__ == "__main__":
    sys.exit(main())
