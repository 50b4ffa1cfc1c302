//! Optics in front of the sensor: vignetting, a thin lens with a finite aperture (depth-dependent
//! defocus) and a Gaussian point-spread function.
//!
//! **Thin lens.** The camera's `fx, fy` are its calibrated focal lengths in pixels at this focus
//! setting (the image distance `v`, not the lens's `f`, over the pixel pitch). The aperture is a
//! disc of diameter `A = focal_length_m / f_number` centred on the camera centre in the plane
//! `z = 0`; the plane `z = focus_distance_m = F` is in focus. The ray of pixel `q` through
//! aperture point `a` passes through the point of the focus plane that the pinhole camera images
//! at `q`. A point at depth `Z` then images at its pinhole pixel plus `f (1/F - 1/Z) a`
//! (`f = fx, fy`), so its circle of confusion has the radius
//! `r_px = fx A / 2 |1/Z - 1/F|` — the thin-lens formula `c = A v |1/Z - 1/F|` over the pixel pitch
//! (Hecht, "Optics", sec. 5.7; Potmesil & Chakravarty 1981). The renderer integrates the aperture
//! with `aperture_samples` points on concentric rings (`ThinLens::aperture_points_m`: the
//! samples' mean and second moment are the disc's exactly), each ray traced exactly.
//!
//! **Vignetting.** The irradiance falls off as `cos^4 theta` of the pixel's ray angle (natural
//! vignetting; Ray, "Applied Photographic Optics", ch. 12) times the radial polynomial
//! `1 + a1 r^2 + a2 r^4 + a3 r^6`, `r` the pixel's distance from the principal point over the
//! half-diagonal of the image (Goldman, "Vignette and exposure calibration", PAMI 2010).

use super::CameraError;

/// Most aperture samples per pixel.
pub const MAX_APERTURE_SAMPLES: u32 = 256;

/// Aperture samples about a pixel apart over a circle of confusion of radius `r_max_px`:
/// `pi r^2`, even, in 16..=[`MAX_APERTURE_SAMPLES`]. Fewer samples image a large circle of
/// confusion as separate copies of the edge (16 samples over a 7.5-px radius: a detector's corners
/// err by 2.6 px RMS, 0.04 px with 256; `experiment robustness`).
pub fn samples_for_coc(r_max_px: f64) -> u32 {
    let want = (std::f64::consts::PI * r_max_px * r_max_px).ceil().clamp(16.0, f64::from(MAX_APERTURE_SAMPLES)) as u32;
    (want + want % 2).min(MAX_APERTURE_SAMPLES)
}

/// Points per ring of `n` aperture samples: `K = max(1, floor(sqrt(n / 3)))` rings, ring `i`
/// holding a share `(2 i + 1) / K^2` (the areas of equal-width annuli), at least three each
/// (the outer ring takes the rounding).
pub fn ring_counts(n: u32) -> Vec<u32> {
    let k = ((f64::from(n) / 3.0).sqrt().floor() as u32).max(1);
    let mut counts: Vec<u32> = (0..k).map(|i| ((f64::from(n) * f64::from(2 * i + 1) / f64::from(k * k)).round() as u32).max(3)).collect();
    let inner: u32 = counts[..counts.len() - 1].iter().sum();
    if let Some(last) = counts.last_mut() {
        *last = n.saturating_sub(inner).max(1);
    }
    counts
}

/// A thin lens's aperture and focus.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ThinLens {
    /// f-number `N` (focal length over aperture diameter).
    pub f_number: f64,
    /// Focal length of the lens, metres.
    pub focal_length_m: f64,
    /// Distance (camera z) of the plane in focus, metres.
    pub focus_distance_m: f64,
    /// Aperture samples per pixel; 0: automatic ([`samples_for_coc`] of the largest circle of
    /// confusion over the target's features).
    pub aperture_samples: u32,
}

impl ThinLens {
    /// The aperture's radius, metres.
    pub fn aperture_radius_m(&self) -> f64 {
        0.5 * self.focal_length_m / self.f_number
    }

    /// The circle of confusion's radius in pixels of focal length `f_px` for a point at camera
    /// depth `depth_m` (`fx A / 2 |1/Z - 1/F|`).
    pub fn coc_radius_px(&self, f_px: f64, depth_m: f64) -> f64 {
        f_px * self.aperture_radius_m() * (1.0 / depth_m - 1.0 / self.focus_distance_m).abs()
    }

    /// The aperture sample points (camera x, y in metres): concentric rings of equally spaced
    /// points ([`ring_counts`]), each ring at the root-mean-square radius of the equal-area
    /// annulus its points stand for. Every ring of three or more points has its centroid at the
    /// lens centre and an isotropic second moment, so the samples reproduce the uniform disc's
    /// mean (0: defocus blurs about the pinhole image without shifting it) and second moment
    /// (`r^2 / 4` along every axis: the blur's spread) exactly.
    pub fn aperture_points_m(&self) -> Vec<[f64; 2]> {
        let n = self.aperture_samples.max(1);
        let r = self.aperture_radius_m();
        let mut pts = Vec::with_capacity(n as usize);
        let mut below = 0u32;
        for (i, m) in ring_counts(n).into_iter().enumerate() {
            let (a0, a1) = (f64::from(below) / f64::from(n), f64::from(below + m) / f64::from(n));
            below += m;
            let rho = if n == 1 { 0.0 } else { r * (0.5 * (a0 + a1)).sqrt() };
            let offset = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            pts.extend((0..m).map(|k| {
                let phi = offset + std::f64::consts::TAU * f64::from(k) / f64::from(m);
                [rho * phi.cos(), rho * phi.sin()]
            }));
        }
        pts
    }

    fn validate(&self) -> Result<(), CameraError> {
        let checks = [("optics.f_number", self.f_number), ("optics.focal_length_m", self.focal_length_m), ("optics.focus_distance_m", self.focus_distance_m)];
        for (field, v) in checks {
            if !(v > 0.0) || !v.is_finite() {
                return Err(CameraError::InvalidParameter { field, reason: format!("must be finite and > 0, got {v}") });
            }
        }
        if self.aperture_samples > MAX_APERTURE_SAMPLES {
            return Err(CameraError::InvalidParameter {
                field: "optics.aperture_samples",
                reason: format!("must be in 0..={MAX_APERTURE_SAMPLES} (0: automatic), got {}", self.aperture_samples),
            });
        }
        Ok(())
    }
}

/// Optics (`[optics]` in scene files). The default is an ideal pinhole: no vignetting, no
/// defocus, no PSF.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Optics {
    /// Whether the irradiance falls off as `cos^4` of the ray angle.
    pub natural_falloff: bool,
    /// Radial polynomial `[a1, a2, a3]` (see the module docs).
    pub vignetting: [f64; 3],
    /// A finite aperture (defocus); `None`: pinhole.
    pub thin_lens: Option<ThinLens>,
    /// Standard deviation of a Gaussian PSF, pixels (0: none).
    pub psf_sigma_px: f64,
}

impl Optics {
    /// Check every field.
    ///
    /// # Errors
    /// [`CameraError::InvalidParameter`] naming the field.
    pub fn validate(&self) -> Result<(), CameraError> {
        if self.vignetting.iter().any(|v| !v.is_finite()) {
            return Err(CameraError::InvalidParameter { field: "optics.vignetting", reason: format!("must be finite, got {:?}", self.vignetting) });
        }
        if !self.psf_sigma_px.is_finite() || !(0.0..=50.0).contains(&self.psf_sigma_px) {
            return Err(CameraError::InvalidParameter { field: "optics.psf_sigma_px", reason: format!("must be in [0, 50], got {}", self.psf_sigma_px) });
        }
        self.thin_lens.as_ref().map_or(Ok(()), ThinLens::validate)
    }

    /// Whether the optics change the image's brightness (vignetting).
    pub fn vignettes(&self) -> bool {
        self.natural_falloff || self.vignetting.iter().any(|v| *v != 0.0)
    }

    /// The relative irradiance at a pixel whose ray makes `cos_theta` with the optical axis and
    /// lies at `r` half-diagonals from the principal point.
    pub fn relative_irradiance(&self, cos_theta: f64, r: f64) -> f64 {
        let natural = if self.natural_falloff { cos_theta.max(0.0).powi(4) } else { 1.0 };
        let r2 = r * r;
        let [a1, a2, a3] = self.vignetting;
        natural * (1.0 + r2 * (a1 + r2 * (a2 + r2 * a3)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coc_follows_the_thin_lens_formula() {
        // f = 16 mm at f/2: aperture 8 mm, radius 4 mm; focus 1 m; fx 1500 px.
        let l = ThinLens { f_number: 2.0, focal_length_m: 0.016, focus_distance_m: 1.0, aperture_samples: 16 };
        assert!((l.aperture_radius_m() - 0.004).abs() < 1e-15);
        assert_eq!(l.coc_radius_px(1500.0, 1.0), 0.0);
        // Z = 0.5 m: 1500 * 0.004 * |2 - 1| = 6 px.
        assert!((l.coc_radius_px(1500.0, 0.5) - 6.0).abs() < 1e-12);
        // Z = 2 m: 1500 * 0.004 * 0.5 = 3 px.
        assert!((l.coc_radius_px(1500.0, 2.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn aperture_points_fill_the_disc_with_its_second_moment() {
        let l = ThinLens { f_number: 2.0, focal_length_m: 0.016, focus_distance_m: 1.0, aperture_samples: 16 };
        let pts = l.aperture_points_m();
        let r = l.aperture_radius_m();
        assert_eq!(pts.len(), 16);
        assert!(pts.iter().all(|p| p[0].hypot(p[1]) <= r));
        // A uniform disc has mean 0 and E[x^2] = E[y^2] = r^2 / 4, E[xy] = 0.
        for n in [3, 8, 16, 17, 32, 64, 100, 256] {
            let pts = ThinLens { aperture_samples: n, ..l }.aperture_points_m();
            assert_eq!(pts.len(), n as usize);
            let avg = |f: &dyn Fn(&[f64; 2]) -> f64| pts.iter().map(f).sum::<f64>() / f64::from(n);
            assert!(avg(&|p| p[0]).abs() < 1e-15 && avg(&|p| p[1]).abs() < 1e-15, "n {n}");
            assert!((avg(&|p| p[0] * p[0]) / (r * r / 4.0) - 1.0).abs() < 1e-12, "n {n}");
            assert!((avg(&|p| p[1] * p[1]) / (r * r / 4.0) - 1.0).abs() < 1e-12, "n {n}");
            assert!(avg(&|p| p[0] * p[1]).abs() < 1e-15, "n {n}");
        }
        assert_eq!(ring_counts(16), vec![4, 12]);
        assert_eq!(ThinLens { aperture_samples: 1, ..l }.aperture_points_m(), vec![[0.0, 0.0]]);
    }

    #[test]
    fn cos4_and_polynomial() {
        let o = Optics { natural_falloff: true, vignetting: [-0.2, 0.0, 0.0], ..Default::default() };
        let c = (30f64).to_radians().cos();
        assert!((o.relative_irradiance(c, 1.0) - c.powi(4) * 0.8).abs() < 1e-15);
        assert!(!Optics::default().vignettes());
        let bad =
            Optics { thin_lens: Some(ThinLens { f_number: -1.0, focal_length_m: 0.01, focus_distance_m: 1.0, aperture_samples: 4 }), ..Default::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("optics.f_number"));
    }
}
