//! Zhang's closed-form initialisation: intrinsics from the plane-to-image homographies of three or
//! more views, and each view's pose.
//!
//! Reference: Z. Zhang, "A flexible new technique for camera calibration", IEEE PAMI 22(11), 2000,
//! section 3.1 and appendix B (course-scenario 1.3).

use nalgebra::{DMatrix, Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3};

use super::CalibError;
use synthcam_core::camera::Intrinsics;
use synthcam_core::math::so3::project_to_so3;

fn v_ij(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 6] {
    let (hi, hj) = (h.column(i), h.column(j));
    [hi[0] * hj[0], hi[0] * hj[1] + hi[1] * hj[0], hi[1] * hj[1], hi[2] * hj[0] + hi[0] * hj[2], hi[2] * hj[1] + hi[1] * hj[2], hi[2] * hj[2]]
}

/// Intrinsics from homographies (board plane z = 0 to pixels). With `zero_skew`, B12 = 0 is
/// imposed as an extra (heavily weighted) equation.
///
/// # Errors
/// [`CalibError::Degenerate`] when the views do not constrain the intrinsics (e.g. all parallel).
pub fn intrinsics_from_homographies(hs: &[Matrix3<f64>], zero_skew: bool) -> Result<Intrinsics, CalibError> {
    let rows = 2 * hs.len() + usize::from(zero_skew);
    let mut v = DMatrix::<f64>::zeros(rows.max(6), 6);
    for (k, h) in hs.iter().enumerate() {
        // Scale each homography so the equations are comparable.
        let h = h / h.column(0).norm().max(1e-300);
        let a = v_ij(&h, 0, 1);
        let (b, c) = (v_ij(&h, 0, 0), v_ij(&h, 1, 1));
        for j in 0..6 {
            v[(2 * k, j)] = a[j];
            v[(2 * k + 1, j)] = b[j] - c[j];
        }
    }
    if zero_skew {
        let scale = v.abs().max().max(1e-300) * 1e3;
        v[(2 * hs.len(), 1)] = scale;
    }
    let svd = v.clone().svd(false, true);
    let vt = svd.v_t.ok_or_else(|| CalibError::Degenerate { reason: "SVD failed".into() })?;
    let mut sv: Vec<f64> = svd.singular_values.iter().copied().collect();
    sv.sort_by(f64::total_cmp);
    if sv.len() >= 2 && !(sv[1] > 1e-9 * sv[sv.len() - 1]) {
        return Err(CalibError::Degenerate { reason: "the views leave the intrinsics undetermined (parallel or too few distinct views)".into() });
    }
    let (imin, _) = svd
        .singular_values
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .ok_or_else(|| CalibError::Degenerate { reason: "no singular values".into() })?;
    let b = vt.row(imin);
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let den = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / den;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / den).sqrt();
    let gamma = if zero_skew { 0.0 } else { -b12 * alpha * alpha * beta / lambda };
    let u0 = gamma * v0 / beta - b13 * alpha * alpha / lambda;
    let k = Intrinsics { fx: alpha, fy: beta, cx: u0, cy: v0, skew: gamma };
    if [k.fx, k.fy, k.cx, k.cy, k.skew].iter().any(|x| !x.is_finite()) || k.fx <= 0.0 || k.fy <= 0.0 {
        return Err(CalibError::Degenerate { reason: "the closed form gives no positive-definite B (degenerate views)".into() });
    }
    Ok(k)
}

/// Pose `cam_from_board` of one view from its homography and the intrinsics.
pub fn pose_from_homography(h: &Matrix3<f64>, k: &Intrinsics) -> Isometry3<f64> {
    let kinv = k.matrix().try_inverse().unwrap_or_else(Matrix3::identity);
    let (h1, h2, h3) = (kinv * h.column(0), kinv * h.column(1), kinv * h.column(2));
    let mut s = 2.0 / (h1.norm() + h2.norm()).max(1e-300);
    if (s * h3).z < 0.0 {
        s = -s;
    }
    let (r1, r2) = (h1 * s, h2 * s);
    let r = project_to_so3(&Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]));
    let t: Vector3<f64> = h3 * s;
    Isometry3::from_parts(Translation3::from(t), UnitQuaternion::from_rotation_matrix(&r))
}
