//! A projective camera fitted by the normalised DLT (Hartley & Zisserman, Multiple View Geometry,
//! 2nd ed., 7.1 and 4.4), with a trimmed refit.

use nalgebra::{Matrix3x4, Matrix4, Point2, Point3, SMatrix, SymmetricEigen, Vector3, Vector4};

use super::grow::trimmed_count;
use super::Pinhole;
use synthcam_core::target::SPath;

/// A camera matrix `P` (3 x 4, pixels): projective, fitted by the DLT, or `K [R | t]` where the
/// intrinsics `K` are known ([`super::pose`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Dlt {
    pub(super) p: Matrix3x4<f64>,
}

impl Dlt {
    /// The camera of the correspondences: projective (11 degrees of freedom), or a pose (6)
    /// behind the intrinsics `pinhole` where they are known (image points then undistorted).
    pub(super) fn fit(world: &[Point3<f64>], image: &[Point2<f64>], pinhole: Pinhole) -> Option<Self> {
        let dlt = Self::fit_projective(world, image);
        match pinhole {
            None => dlt,
            Some(k) => super::pose::fit_pose(k, world, image, dlt.as_ref()).map(|p| Self { p }),
        }
    }

    /// Normalised DLT from at least 6 correspondences; `None` when they are degenerate.
    fn fit_projective(world: &[Point3<f64>], image: &[Point2<f64>]) -> Option<Self> {
        let n = world.len();
        if n < 6 || image.len() != n {
            return None;
        }
        let m2 = image.iter().fold(Vector3::zeros(), |a, p| a + p.coords.push(1.0)) / n as f64;
        let s2 = image.iter().map(|p| (p.coords - m2.xy()).norm()).sum::<f64>() / n as f64;
        let m3 = world.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n as f64;
        let s3 = world.iter().map(|p| (p.coords - m3).norm()).sum::<f64>() / n as f64;
        if !(s2 > 1e-9 && s3 > 1e-12) {
            return None;
        }
        let (k2, k3) = (std::f64::consts::SQRT_2 / s2, 3f64.sqrt() / s3);
        let mut ata = SMatrix::<f64, 12, 12>::zeros();
        for (x, u) in world.iter().zip(image) {
            let xs = ((x.coords - m3) * k3).push(1.0);
            let us = (u.coords - m2.xy()) * k2;
            let mut r1 = SMatrix::<f64, 1, 12>::zeros();
            let mut r2 = SMatrix::<f64, 1, 12>::zeros();
            for c in 0..4 {
                r1[c] = xs[c];
                r1[8 + c] = -us.x * xs[c];
                r2[4 + c] = xs[c];
                r2[8 + c] = -us.y * xs[c];
            }
            ata += r1.transpose() * r1 + r2.transpose() * r2;
        }
        let eig = SymmetricEigen::new(ata);
        let mut order: Vec<usize> = (0..12).collect();
        order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
        let (l0, l1, lmax) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]], eig.eigenvalues[order[11]]);
        // A one-dimensional null space: the second-smallest eigenvalue well above round-off.
        if !(l1 > 1e-10 * lmax) || !l0.is_finite() {
            return None;
        }
        let v = eig.eigenvectors.column(order[0]);
        let ps = Matrix3x4::from_row_slice(v.as_slice());
        let t2_inv = nalgebra::Matrix3::new(1.0 / k2, 0.0, m2.x, 0.0, 1.0 / k2, m2.y, 0.0, 0.0, 1.0);
        let t3 = Matrix4::new(k3, 0.0, 0.0, -k3 * m3.x, 0.0, k3, 0.0, -k3 * m3.y, 0.0, 0.0, k3, -k3 * m3.z, 0.0, 0.0, 0.0, 1.0);
        let mut p = t2_inv * ps * t3;
        // Points in front: positive third coordinate for most of them.
        let front = world.iter().filter(|x| (p * x.to_homogeneous())[2] > 0.0).count();
        if 2 * front < n {
            p = -p;
        }
        p.iter().all(|v| v.is_finite()).then_some(Self { p })
    }

    /// Fit, then refit to the [`super::grow::TRIM_KEEP`] share of the pairs it fits best: a few mislabelled
    /// dots (a skip miscounted where dots stray from the nominal curve) then cannot drag the
    /// camera, and the matching that follows relabels them.
    pub(super) fn fit_trimmed(world: &[Point3<f64>], image: &[Point2<f64>], pinhole: Pinhole) -> Option<Self> {
        let dlt = Self::fit(world, image, pinhole)?;
        let keep = trimmed_count(world.len());
        if keep >= world.len() {
            return Some(dlt);
        }
        let mut err: Vec<(f64, usize)> =
            world.iter().zip(image).enumerate().map(|(k, (x, u))| (dlt.project(x).map_or(f64::INFINITY, |q| (q - u).norm()), k)).collect();
        err.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (w, i): (Vec<Point3<f64>>, Vec<Point2<f64>>) = err[..keep].iter().map(|&(_, k)| (world[k], image[k])).unzip();
        Self::fit(&w, &i, pinhole).or(Some(dlt))
    }

    pub(super) fn project(&self, x: &Point3<f64>) -> Option<Point2<f64>> {
        let y = self.p * x.to_homogeneous();
        (y[2] > 0.0).then(|| Point2::new(y[0] / y[2], y[1] / y[2]))
    }

    /// Reprojection RMS, pixels (points behind the camera count as 1e6 px).
    pub(super) fn rms(&self, world: &[Point3<f64>], image: &[Point2<f64>]) -> f64 {
        let ss: f64 = world.iter().zip(image).map(|(x, u)| self.project(x).map_or(1e12, |q| (q - u).norm_squared())).sum();
        (ss / world.len().max(1) as f64).sqrt()
    }

    /// Image distance from `q` (the projection of path point `i`) to the projection of the
    /// nearer path neighbour (hidden neighbours projected anyway).
    pub(super) fn spacing_at(&self, path: &SPath, i: usize, q: &Point2<f64>) -> f64 {
        [i.checked_sub(1), Some(i + 1)]
            .into_iter()
            .flatten()
            .filter(|&k| k < path.len())
            .filter_map(|k| self.project(&path.points_m[k]).map(|p| (p - q).norm()))
            .fold(f64::INFINITY, f64::min)
    }

    /// The camera centre (homogeneous null vector of P), when finite.
    pub(super) fn centre(&self) -> Option<Point3<f64>> {
        let col = |i: usize| self.p.column(i).into_owned();
        let det = |a: usize, b: usize, c: usize| nalgebra::Matrix3::from_columns(&[col(a), col(b), col(c)]).determinant();
        let c = Vector4::new(det(1, 2, 3), -det(0, 2, 3), det(0, 1, 3), -det(0, 1, 2));
        (c[3].abs() > 1e-12).then(|| Point3::new(c[0] / c[3], c[1] / c[3], c[2] / c[3]))
    }
}
