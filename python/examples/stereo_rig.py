"""Render a stereo rig's synchronised views, calibrate the rig from the detected corners and
print the extrinsics' error against the rendered truth (issue 40's rig: two 1280 x 1024
pinholes, 12 cm baseline, 2 degrees of toe-in, noise sigma 1).

    python python/examples/stereo_rig.py      (from the repository root)
"""
import numpy as np
import synthcam

left = {"width": 1280, "height": 1024, "fx": 1100.0, "fy": 1100.0, "cx": 639.5, "cy": 511.5, "dist": [-0.15, 0.05, 0.0, 0.0, 0.0]}
right = {**left, "fx": 1120.0, "fy": 1120.0, "dist": [-0.1, 0.03, 0.0, 0.0, 0.0]}
# The truth: rig_from_right (the left camera is the rig frame).
R_lr, t_lr = synthcam.rotation_from_rvec([0.0, -np.radians(2.0), 0.0]), np.array([0.12, 0.0, 0.0])
target = {"kind": "chessboard", "squares": [9, 7], "square_m": 0.03}
rng = np.random.default_rng(40)
detections = {"left": [], "right": []}
while len(detections["left"]) < 20:
    # cam_from_target of the left camera: the board 0.45-0.7 m away, tilted up to ~30 degrees.
    R = synthcam.rotation_from_rvec(rng.uniform(-0.5, 0.5, 3) * [1.0, 1.0, 0.3])
    t = np.array([rng.uniform(-0.06, 0.1), rng.uniform(-0.1, 0.0), rng.uniform(0.45, 0.7)]) - R @ [0.15, 0.12, 0.0]
    poses = {"left": (R, t), "right": (R_lr.T @ R, R_lr.T @ (t - t_lr))}
    found = {}
    for name, cam in (("left", left), ("right", right)):
        scene = {"camera": cam, "target": target, "pose": synthcam.pose(poses[name][1], R=poses[name][0]),
                 "render": {"noise_sigma": 1.0, "seed": int(rng.integers(1 << 31))}}
        image, truth = synthcam.render(scene)
        found[name] = synthcam.detect(image, "chessboard:8x6") if truth.visible.all() else None
    if found["left"] is not None and found["right"] is not None and found["left"].found and found["right"].found:
        for name in found:
            detections[name].append(found[name])
rig = synthcam.calibrate_rig(
    [{"name": n, "image_size": (1280, 1024), "detections": d} for n, d in detections.items()], "chessboard:8x6", 0.03
)
est = rig.cameras[1].cam0_from_cam
dt_mm = 1e3 * np.linalg.norm(est.t_m - t_lr)
dr = np.degrees(np.linalg.norm(synthcam.Pose(R_lr.T @ est.R, np.zeros(3)).rvec))
print(f"rig RMS {rig.rms_px:.4f} px; baseline error {dt_mm:.4f} mm (sigma {1e3 * np.linalg.norm(rig.cameras[1].translation_std_m):.4f} mm), "
      f"rotation error {dr:.5f} deg; rectified rows mean {rig.rectified_row_error_mean_px:.4f} px")
