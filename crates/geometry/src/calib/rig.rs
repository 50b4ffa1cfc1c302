//! Joint calibration of a camera rig: every camera's intrinsics, every `cam0_from_camN` and every
//! frame's board pose in one bundle adjustment, from synchronised frames in which any subset of
//! the cameras sees the board (as Kalibr and mrcal do; OpenCV's `stereoCalibrate` for two).
//!
//! Start: each camera calibrated alone ([`super::calibrate`], its own global search), then each
//! `camN_from_cam0` from the frames camera 0 and camera N both see (the chordal mean of the
//! rotations, the mean of the translations), each frame's `cam0_from_board` from camera 0's view
//! or, where camera 0 did not see it, through another camera's extrinsics. Then
//! Levenberg-Marquardt over `[intrinsics of every camera, the extrinsics of cameras 1..]` (the
//! global block) and the frames' poses (eliminated by the Schur complement, as in
//! [`super::refine`]).
//!
//! Parameters per extrinsic: `camN_from_cam0` as `[rvec (3), t (3)]` (rvec additive, as the
//! poses). Reported: `cam0_from_camN` (its inverse) and its standard deviations, rotation in
//! degrees (the rotation vector's) and translation in the board's unit, propagated through the
//! inverse.
//!
//! References: R. Hartley, A. Zisserman, *Multiple View Geometry*, 2nd ed., appendix A6 (sparse
//! Levenberg-Marquardt); Kalibr's camera-chain calibration (Furgale et al., IROS 2013); the
//! chordal L2 rotation mean (Hartley et al., "Rotation averaging", IJCV 2013, section 5.3).

use nalgebra::{DMatrix, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3, Vector6};

mod lm;

use super::refine::{camera_of, pose_vector, vector_of, View};
use super::{calibrate, CalibError, CalibParams};
use lm::{lm, residual, Layout, Obs, RigState};
use synthcam_core::camera::{CameraModel, ImageSize, N_INTRINSICS};
use synthcam_core::math::so3::{project_to_so3, rotation_from_rvec};

/// One camera of a rig: its image size, the model to estimate, and its view of each frame
/// (`None`: it did not see the board in that frame). Every camera has one entry per frame.
#[derive(Debug, Clone)]
pub struct RigCamera {
    /// A name, unique in the rig.
    pub name: String,
    /// Image size.
    pub size: ImageSize,
    /// Its calibration options (the lens model; outlier rejection is applied per camera in the
    /// start).
    pub params: CalibParams,
    /// Per frame, its view of the board.
    pub views: Vec<Option<View>>,
}

/// One camera of a [`RigResult`].
#[derive(Debug, Clone, PartialEq)]
pub struct RigCameraResult {
    /// The name.
    pub name: String,
    /// The calibrated camera.
    pub camera: CameraModel,
    /// Standard deviations of its intrinsics ([`super::IntrinsicStd`] order; NaN for fixed ones).
    pub std: super::IntrinsicStd,
    /// `cam0_from_cam` (identity for camera 0).
    pub cam0_from_cam: Isometry3<f64>,
    /// Standard deviation of `cam0_from_cam`'s rotation vector, degrees (zero for camera 0).
    pub rotation_std_deg: [f64; 3],
    /// Standard deviation of `cam0_from_cam`'s translation, board units (zero for camera 0).
    pub translation_std: [f64; 3],
    /// RMS reprojection error of this camera's points, px.
    pub rms_px: f64,
    /// Its points used.
    pub points: usize,
}

/// Result of [`calibrate_rig`].
#[derive(Debug, Clone, PartialEq)]
pub struct RigResult {
    /// Per camera.
    pub cameras: Vec<RigCameraResult>,
    /// RMS over every camera's points, px (as `stereoCalibrate` returns it).
    pub rms_px: f64,
    /// Per frame, `cam0_from_board` (`None`: no camera saw the board).
    pub cam0_from_board: Vec<Option<Isometry3<f64>>>,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
}

fn iso(v: &Vector6<f64>) -> Isometry3<f64> {
    let r = rotation_from_rvec(&Vector3::new(v[0], v[1], v[2]));
    Isometry3::from_parts(Translation3::new(v[3], v[4], v[5]), UnitQuaternion::from_rotation_matrix(&r))
}

/// Check the rig's shape: names unique, one entry per frame for every camera, at least two cameras.
fn validate(cams: &[RigCamera]) -> Result<usize, CalibError> {
    if cams.len() < 2 {
        return Err(CalibError::BadOption { reason: format!("a rig needs at least 2 cameras, got {}", cams.len()) });
    }
    let frames = cams[0].views.len();
    for (i, c) in cams.iter().enumerate() {
        if cams[..i].iter().any(|o| o.name == c.name) {
            return Err(CalibError::BadOption { reason: format!("two cameras are named {:?}", c.name) });
        }
        if c.views.len() != frames {
            return Err(CalibError::BadOption { reason: format!("camera {:?} has {} frames, camera {:?} {frames}", c.name, c.views.len(), cams[0].name) });
        }
    }
    Ok(frames)
}

/// Calibrate a rig (module documentation).
///
/// # Errors
/// [`CalibError::BadOption`] for fewer than 2 cameras, duplicate names or cameras with different
/// frame counts; any error of a camera's own calibration (too few views, degenerate data), named
/// by the camera; [`CalibError::Degenerate`] when a camera shares no frame with camera 0 (its
/// extrinsics have no start) or the normal equations are singular.
pub fn calibrate_rig(cams: &[RigCamera], max_iterations: usize) -> Result<RigResult, CalibError> {
    let n_frames = validate(cams)?;
    let singles = cams
        .iter()
        .map(|c| {
            let (views, idx): (Vec<View>, Vec<usize>) = c.views.iter().enumerate().filter_map(|(k, v)| v.clone().map(|v| (v, k))).unzip();
            let r = calibrate(&views, c.size, &c.params).map_err(|e| CalibError::BadOption { reason: format!("camera {:?}: {e}", c.name) })?;
            let mut poses: Vec<Option<Isometry3<f64>>> = vec![None; n_frames];
            let mut dropped: Vec<Vec<usize>> = vec![Vec::new(); n_frames];
            for (v, k) in r.views.iter().zip(idx) {
                poses[k] = Some(iso(&Vector6::new(v.rvec.x, v.rvec.y, v.rvec.z, v.tvec.x, v.tvec.y, v.tvec.z)));
                dropped[k].clone_from(&v.outliers);
            }
            Ok((r, poses, dropped))
        })
        .collect::<Result<Vec<_>, CalibError>>()?;
    let poses: Vec<Vec<Option<Isometry3<f64>>>> = singles.iter().map(|(_, p, _)| p.clone()).collect();
    let ext = initial_extrinsics(cams, &poses)?;
    let frames = initial_frames(&poses, &ext);
    // The frames some camera saw are the parameters; `slot[k]`: frame k's place among them.
    let mut seen = 0;
    let slot: Vec<Option<usize>> = frames
        .iter()
        .map(|f| {
            f.map(|_| {
                seen += 1;
                seen - 1
            })
        })
        .collect();
    // Every point of every view, less those each camera's own calibration dropped as outliers.
    let obs: Vec<Obs> = cams
        .iter()
        .enumerate()
        .flat_map(|(c, cam)| cam.views.iter().zip(&slot).enumerate().filter_map(move |(k, (v, f))| Some((c, k, (*f)?, v.as_ref()?))))
        .flat_map(|(c, k, frame, v)| {
            let dropped = &singles[c].2[k];
            v.iter().enumerate().filter(move |(j, _)| !dropped.contains(j)).map(move |(_, (x, q))| Obs { cam: c, frame, x: *x, q: *q })
        })
        .collect();
    let state = RigState {
        a: singles.iter().map(|(r, _, _)| vector_of(&r.camera)).collect(),
        ext: ext.iter().skip(1).map(pose_vector).collect(),
        frames: frames.iter().flatten().map(pose_vector).collect(),
    };
    let layout = Layout::new(cams);
    let (st, cov, iterations) = lm(cams, &layout, state, &obs, max_iterations)?;
    Ok(result(cams, &layout, &st, &cov, &obs, &slot, iterations))
}

/// `camN_from_cam0` per camera (identity for camera 0) from the frames both see.
fn initial_extrinsics(cams: &[RigCamera], poses: &[Vec<Option<Isometry3<f64>>>]) -> Result<Vec<Isometry3<f64>>, CalibError> {
    let mut out = vec![Isometry3::identity()];
    for (c, p) in poses.iter().enumerate().skip(1) {
        let pairs: Vec<Isometry3<f64>> = p.iter().zip(&poses[0]).filter_map(|(a, b)| Some(a.as_ref()? * b.as_ref()?.inverse())).collect();
        if pairs.is_empty() {
            return Err(CalibError::Degenerate { reason: format!("camera {:?} sees the board in no frame camera {:?} sees", cams[c].name, cams[0].name) });
        }
        let m: Matrix3<f64> = pairs.iter().map(|e| *e.rotation.to_rotation_matrix().matrix()).sum();
        let rot = UnitQuaternion::from_rotation_matrix(&project_to_so3(&m));
        let t: Vector3<f64> = pairs.iter().map(|e| e.translation.vector).sum::<Vector3<f64>>() / pairs.len() as f64;
        out.push(Isometry3::from_parts(t.into(), rot));
    }
    Ok(out)
}

/// Each frame's `cam0_from_board`: camera 0's pose, else the first camera's that saw it,
/// carried by its extrinsics.
fn initial_frames(poses: &[Vec<Option<Isometry3<f64>>>], ext: &[Isometry3<f64>]) -> Vec<Option<Isometry3<f64>>> {
    (0..poses[0].len()).map(|k| poses.iter().zip(ext).find_map(|(p, e)| p[k].map(|camc_from_board| e.inverse() * camc_from_board))).collect()
}

fn result(cams: &[RigCamera], lay: &Layout, st: &RigState, cov: &DMatrix<f64>, obs: &[Obs], slot: &[Option<usize>], iterations: usize) -> RigResult {
    let mut ss = vec![(0.0, 0usize); cams.len()];
    for o in obs {
        ss[o.cam].0 += residual(cams, lay, st, o).0.norm_squared();
        ss[o.cam].1 += 1;
    }
    let cameras = cams
        .iter()
        .enumerate()
        .map(|(c, cam)| {
            let (free, col0) = &lay.free[c];
            let mut std = [f64::NAN; N_INTRINSICS];
            for (j, &f) in free.iter().enumerate() {
                std[f] = cov[(col0 + j, col0 + j)].sqrt();
            }
            let (cam0_from_cam, rotation_std_deg, translation_std) = match c {
                0 => (Isometry3::identity(), [0.0; 3], [0.0; 3]),
                _ => extrinsic_out(&st.ext[c - 1], cov, lay.ext0 + 6 * (c - 1)),
            };
            RigCameraResult {
                name: cam.name.clone(),
                camera: camera_of(cam.size, cam.params.model.kind(), &st.a[c]),
                std,
                cam0_from_cam,
                rotation_std_deg,
                translation_std,
                rms_px: (ss[c].0 / ss[c].1.max(1) as f64).sqrt(),
                points: ss[c].1,
            }
        })
        .collect();
    let total: f64 = ss.iter().map(|s| s.0).sum();
    let n: usize = ss.iter().map(|s| s.1).sum();
    RigResult { cameras, rms_px: (total / n.max(1) as f64).sqrt(), cam0_from_board: slot.iter().map(|s| s.map(|i| iso(&st.frames[i]))).collect(), iterations }
}

/// `cam0_from_cam` from `camN_from_cam0` and its standard deviations: the rotation's (its rvec
/// negated: same spread, degrees) and the translation's `-R^T t`, propagated by its Jacobian
/// `[-R^T [t]x-free part, -R^T]` numerically (central differences over the 6 parameters).
fn extrinsic_out(e: &Vector6<f64>, cov: &DMatrix<f64>, col: usize) -> (Isometry3<f64>, [f64; 3], [f64; 3]) {
    let inv_t = |v: &Vector6<f64>| iso(v).inverse().translation.vector;
    let c6 = cov.view((col, col), (6, 6)).into_owned();
    let mut j = DMatrix::zeros(3, 6);
    for k in 0..6 {
        let h = 1e-7 * (1.0 + e[k].abs());
        let (mut a, mut b) = (*e, *e);
        a[k] += h;
        b[k] -= h;
        let d = (inv_t(&a) - inv_t(&b)) / (2.0 * h);
        j.set_column(k, &d);
    }
    let ct = &j * c6 * j.transpose();
    let rot_std = std::array::from_fn(|i| cov[(col + i, col + i)].sqrt().to_degrees());
    (iso(e).inverse(), rot_std, std::array::from_fn(|i| ct[(i, i)].sqrt()))
}

/// The row (epipolar) error of the first two cameras' corners after rectification
/// ([`super::rectify::stereo_rectify`], OpenCV's `stereoRectify`): every corner seen by both
/// cameras in a frame unprojected by its camera, rotated into its rectified frame, projected
/// with the rectified focal length; (mean, max) px of the row difference (the column difference
/// for a vertical pair) over the corners both see; `None` without a shared corner or when the
/// pair cannot be rectified. The check ROS's `camera_calibration` and OpenCV's tutorial report.
pub fn rectified_row_errors(r: &RigResult, cams: &[RigCamera]) -> Option<(f64, f64)> {
    let (c0, c1) = (r.cameras.first()?, r.cameras.get(1)?);
    let rect = super::rectify::stereo_rectify(&c0.camera, &c1.camera, &c1.cam0_from_cam.inverse()).ok()?;
    let axis = usize::from(!rect.vertical);
    let f = rect.focal_px();
    let row = |cam: &CameraModel, rot: &Matrix3<f64>, q: &nalgebra::Point2<f64>| {
        let v = rot * cam.unproject_ray(q).ok()?;
        (v.z > 0.0).then(|| f * v[axis] / v.z)
    };
    let mut errs = Vec::new();
    for (v0, v1) in cams.first()?.views.iter().zip(&cams.get(1)?.views) {
        let (Some(v0), Some(v1)) = (v0, v1) else { continue };
        for (x, q0) in v0 {
            let Some((_, q1)) = v1.iter().find(|(x1, _)| (x1 - x).norm() < 1e-12) else { continue };
            if let (Some(y0), Some(y1)) = (row(&c0.camera, &rect.r1, q0), row(&c1.camera, &rect.r2, q1)) {
                errs.push((y0 - y1).abs());
            }
        }
    }
    (!errs.is_empty()).then(|| (errs.iter().sum::<f64>() / errs.len() as f64, errs.iter().copied().fold(0.0, f64::max)))
}
