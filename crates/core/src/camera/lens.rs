//! The lens models a [`super::CameraModel`] can have, behind one interface on normalised
//! coordinates: `xd = distort(xu)` maps the ray `(xu, yu, 1)` to the distorted normalised point,
//! and pixels are `K xd` for every model. A fisheye also maps rays at and beyond 90 degrees from
//! the axis ([`Fisheye::distort_ray`], [`Fisheye::undistort_ray`]; the camera's `project` and
//! `unproject_ray` use them).
//!
//! | model | parameters (this order) | OpenCV | Kalibr | ROS `distortion_model` |
//! |---|---|---|---|---|
//! | [`Lens::OpenCv`] | `k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 s4 tau_x tau_y` | `projectPoints` | `pinhole-radtan` (k1 k2 p1 p2) | `plumb_bob` (5), `rational_polynomial` (8) |
//! | [`Lens::Fisheye`] | `k1 k2 k3 k4` | `cv::fisheye` | `pinhole-equi` | `equidistant` |
//! | [`Lens::DoubleSphere`] | `xi alpha` | - | `ds-none` (`[xi, alpha, fu, fv, pu, pv]`) | - |
//!
//! Bouguet's `k1..k5` map to OpenCV's `k1, k2, p1, p2, k3` (see [`super`]).

use nalgebra::{Matrix2, SMatrix, Vector2, Vector3};

use super::{CameraError, Distortion, DoubleSphere, Fisheye, MAX_RAY_ANGLE_RAD};

/// Most lens parameters of any model (OpenCV's 14).
pub const MAX_LENS_PARAMS: usize = 14;

/// The lens of a camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lens {
    /// OpenCV's model (`cv::projectPoints`), up to 14 coefficients.
    OpenCv(Distortion),
    /// OpenCV's fisheye model (Kannala-Brandt, 4 coefficients).
    Fisheye(Fisheye),
    /// Usenko et al.'s Double Sphere model.
    DoubleSphere(DoubleSphere),
}

impl Default for Lens {
    fn default() -> Self {
        Self::OpenCv(Distortion::default())
    }
}

/// Which model a [`Lens`] is (the scene files' `model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LensKind {
    /// `"opencv"`.
    OpenCv,
    /// `"fisheye"`.
    Fisheye,
    /// `"double-sphere"`.
    DoubleSphere,
}

impl LensKind {
    /// The scene files' name of the model.
    pub fn name(self) -> &'static str {
        match self {
            Self::OpenCv => "opencv",
            Self::Fisheye => "fisheye",
            Self::DoubleSphere => "double-sphere",
        }
    }

    /// The model's parameter names, in the order of [`Lens::params`].
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            Self::OpenCv => &["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y"],
            Self::Fisheye => &["k1", "k2", "k3", "k4"],
            Self::DoubleSphere => &["xi", "alpha"],
        }
    }

    /// The lens of this kind with `params` (missing trailing values 0, extra ignored).
    pub fn lens(self, params: &[f64]) -> Lens {
        let mut a = [0.0; MAX_LENS_PARAMS];
        for (d, s) in a.iter_mut().zip(params) {
            *d = *s;
        }
        match self {
            Self::OpenCv => Lens::OpenCv(Distortion::from_coefficients(a)),
            Self::Fisheye => Lens::Fisheye(Fisheye { k: [a[0], a[1], a[2], a[3]] }),
            Self::DoubleSphere => Lens::DoubleSphere(DoubleSphere { xi: a[0], alpha: a[1] }),
        }
    }
}

impl Lens {
    /// The model of this lens.
    pub fn kind(&self) -> LensKind {
        match self {
            Self::OpenCv(_) => LensKind::OpenCv,
            Self::Fisheye(_) => LensKind::Fisheye,
            Self::DoubleSphere(_) => LensKind::DoubleSphere,
        }
    }

    /// The parameters in [`LensKind::param_names`] order, zero-padded to [`MAX_LENS_PARAMS`].
    pub fn params(&self) -> [f64; MAX_LENS_PARAMS] {
        let mut a = [0.0; MAX_LENS_PARAMS];
        match self {
            Self::OpenCv(d) => a = d.coefficients(),
            Self::Fisheye(f) => a[..4].copy_from_slice(&f.k),
            Self::DoubleSphere(d) => a[..2].copy_from_slice(&[d.xi, d.alpha]),
        }
        a
    }

    /// Number of parameters of the model.
    pub fn n_params(&self) -> usize {
        self.kind().param_names().len()
    }

    /// The OpenCV distortion, if this is the OpenCV model.
    pub fn opencv(&self) -> Option<&Distortion> {
        match self {
            Self::OpenCv(d) => Some(d),
            _ => None,
        }
    }

    /// Whether `distort` is the identity (a pinhole camera).
    pub fn is_identity(&self) -> bool {
        match self {
            Self::OpenCv(d) => d.is_zero(),
            Self::Fisheye(_) => false,
            Self::DoubleSphere(d) => d.xi == 0.0 && d.alpha == 0.0,
        }
    }

    /// Checks the parameters: finite; Double Sphere `xi` in `[-1, 1]`, `alpha` in `[0, 1)`.
    pub fn validate(&self) -> Result<(), CameraError> {
        let names = self.kind().param_names();
        for (name, v) in names.iter().zip(self.params()) {
            if !v.is_finite() {
                return Err(CameraError::InvalidParameter { field: name, reason: format!("lens parameter must be finite, got {v}") });
            }
        }
        if let Self::DoubleSphere(d) = self {
            if !(-1.0..=1.0).contains(&d.xi) {
                return Err(CameraError::InvalidParameter { field: "xi", reason: format!("must be in [-1, 1], got {}", d.xi) });
            }
            if !(0.0..1.0).contains(&d.alpha) {
                return Err(CameraError::InvalidParameter { field: "alpha", reason: format!("must be in [0, 1), got {}", d.alpha) });
            }
        }
        Ok(())
    }

    /// Distorted normalised point of the ray `(xu, 1)`.
    pub fn distort(&self, xu: &Vector2<f64>) -> Vector2<f64> {
        match self {
            Self::OpenCv(d) => d.distort(xu),
            Self::Fisheye(f) => f.distort(xu),
            Self::DoubleSphere(d) => d.distort(xu),
        }
    }

    /// `d xd / d xu` (2 x 2).
    pub fn dxd_dxu(&self, xu: &Vector2<f64>) -> Matrix2<f64> {
        match self {
            Self::OpenCv(d) => d.dxd_dxu(xu),
            Self::Fisheye(f) => f.dxd_dxu(xu),
            Self::DoubleSphere(d) => d.dxd_dxu(xu),
        }
    }

    /// `d xd / d params` (2 x 14; columns past [`Self::n_params`] are zero).
    pub fn dxd_dparams(&self, xu: &Vector2<f64>) -> SMatrix<f64, 2, MAX_LENS_PARAMS> {
        self.dxd_dparams_n(xu, MAX_LENS_PARAMS)
    }

    /// [`Self::dxd_dparams`] where only the first `n` columns are needed (OpenCV: the tilt
    /// columns, which cost two rotation matrices per point, are left zero when `n <= 12`).
    pub fn dxd_dparams_n(&self, xu: &Vector2<f64>, n: usize) -> SMatrix<f64, 2, MAX_LENS_PARAMS> {
        let mut j = SMatrix::<f64, 2, MAX_LENS_PARAMS>::zeros();
        match self {
            Self::OpenCv(d) => j = d.dxd_dcoeffs_n(xu, n > 12),
            Self::Fisheye(f) => j.fixed_view_mut::<2, 4>(0, 0).copy_from(&f.dxd_dcoeffs(xu)),
            Self::DoubleSphere(d) => j.fixed_view_mut::<2, 2>(0, 0).copy_from(&d.dxd_dparams(xu)),
        }
        j
    }

    /// Distorted normalised point of the camera-frame point `p`: [`Self::distort`] of
    /// `p.xy / p.z`, except that a fisheye takes its angle from the axis by atan2
    /// ([`Fisheye::distort_ray`], also behind the camera plane).
    pub fn distort_point(&self, p: &Vector3<f64>) -> Vector2<f64> {
        match self {
            Self::Fisheye(f) => f.distort_ray(p),
            _ => self.distort(&Vector2::new(p.x / p.z, p.y / p.z)),
        }
    }

    /// [`Self::dxd_dparams_n`] at the camera-frame point `p` (a fisheye's by atan2, as
    /// [`Self::distort_point`]).
    pub fn dxd_dparams_point(&self, p: &Vector3<f64>, n: usize) -> SMatrix<f64, 2, MAX_LENS_PARAMS> {
        match self {
            Self::Fisheye(f) => {
                let mut j = SMatrix::<f64, 2, MAX_LENS_PARAMS>::zeros();
                j.fixed_view_mut::<2, 4>(0, 0).copy_from(&f.dxd_dcoeffs_ray(p));
                j
            }
            _ => self.dxd_dparams_n(&Vector2::new(p.x / p.z, p.y / p.z), n),
        }
    }

    /// The ray `(xu, 1)` of a distorted normalised point.
    ///
    /// # Errors
    /// [`CameraError::NonFinite`], [`CameraError::NotInvertible`] outside the model's valid region.
    pub fn undistort(&self, xd: &Vector2<f64>) -> Result<Vector2<f64>, CameraError> {
        match self {
            Self::OpenCv(d) => d.undistort(xd),
            Self::Fisheye(f) => f.undistort(xd),
            Self::DoubleSphere(d) => d.undistort(xd),
        }
    }

    /// The largest `|xu|` of the model's valid (one-to-one) region, `None` if unbounded.
    pub fn max_radius(&self) -> Option<f64> {
        match self {
            Self::OpenCv(d) => d.max_monotonic_radius(),
            Self::Fisheye(f) => Some(f.theta_max().min(MAX_RAY_ANGLE_RAD).tan()),
            Self::DoubleSphere(d) => Some(d.max_radius()),
        }
    }

    /// The largest angle from the optical axis (radians) of the model's valid region: beyond 90
    /// degrees only for a fisheye ([`Fisheye::theta_max`]); `pi / 2` for an unbounded OpenCV lens.
    pub fn max_angle_rad(&self) -> f64 {
        match self {
            Self::Fisheye(f) => f.theta_max(),
            _ => self.max_radius().map_or(std::f64::consts::FRAC_PI_2, f64::atan),
        }
    }
}

#[cfg(test)]
mod tests;
