//! Homography between a plane and the image by the normalised DLT.
//!
//! Reference: Hartley & Zisserman, Multiple View Geometry, 2nd ed., Algorithm 4.2 (normalised DLT).

use nalgebra::{DMatrix, Matrix3, Point2};

/// Similarity that moves `pts` to zero mean and mean distance sqrt(2) (Hartley normalisation).
fn normaliser(pts: &[Point2<f64>]) -> Matrix3<f64> {
    let n = pts.len().max(1) as f64;
    let c = pts.iter().fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords) / n;
    let d = pts.iter().map(|p| (p.coords - c).norm()).sum::<f64>() / n;
    let s = if d > 0.0 { std::f64::consts::SQRT_2 / d } else { 1.0 };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

/// Homography `H` with `dst ~ H src`, from 4 or more correspondences; `None` when degenerate.
pub fn homography(src: &[Point2<f64>], dst: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    if src.len() < 4 || src.len() != dst.len() {
        return None;
    }
    let (ts, td) = (normaliser(src), normaliser(dst));
    let rows = (2 * src.len()).max(9);
    let mut a = DMatrix::<f64>::zeros(rows, 9);
    for (k, (s, d)) in src.iter().zip(dst).enumerate() {
        let s = ts * s.to_homogeneous();
        let d = td * d.to_homogeneous();
        let (x, y, u, v) = (s.x, s.y, d.x, d.y);
        let r0 = [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u];
        let r1 = [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v];
        for c in 0..9 {
            a[(2 * k, c)] = r0[c];
            a[(2 * k + 1, c)] = r1[c];
        }
    }
    let svd = a.svd(false, true);
    let vt = svd.v_t?;
    let (imin, _) = svd.singular_values.iter().enumerate().min_by(|a, b| a.1.total_cmp(b.1))?;
    let h = vt.row(imin);
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let hm = td.try_inverse()? * hn * ts;
    let scale = hm[(2, 2)];
    (scale.abs() > 1e-300 && hm.iter().all(|v| v.is_finite())).then(|| hm / scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_known_homography() {
        let h = Matrix3::new(700.0, 20.0, 320.0, -10.0, 650.0, 240.0, 0.05, -0.02, 1.0);
        let src: Vec<Point2<f64>> = (0..20).map(|i| Point2::new(f64::from(i % 5) * 0.1, f64::from(i / 5) * 0.1)).collect();
        let dst: Vec<Point2<f64>> = src.iter().map(|p| Point2::from_homogeneous(h * p.to_homogeneous()).unwrap()).collect();
        let e = homography(&src, &dst).unwrap();
        assert!((e - h).abs().max() < 1e-8 * h.abs().max(), "{e}");
        assert!(homography(&src[..3], &dst[..3]).is_none());
    }
}
