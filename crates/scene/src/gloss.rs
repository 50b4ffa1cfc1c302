//! A glossy coating on the target (`[render] specular`, `roughness`): GGX microfacet reflection
//! of the point light ([`crate::lighting`]).

use nalgebra::Vector3;

/// A glossy coating on the target (a laminated board): GGX microfacet reflection of the point
/// light, added to the diffuse shading (not scaled by the albedo).
///
/// In grey levels the term is `pi 255 f_s E_l cos_l` with `f_s = D G F / (4 cos_l cos_v)` the
/// Cook-Torrance BRDF (GGX `D` with `alpha = roughness^2`, Smith-Schlick `G` with `k = alpha / 2`,
/// Schlick's Fresnel `F` from `specular` at normal incidence), `E_l` the lamp's irradiance: the
/// scale at which a white Lambertian surface (albedo 1, BRDF `1 / pi`) shows 255.
///
/// Reference: B. Walter et al., "Microfacet models for refraction through rough surfaces",
/// EGSR 2007 (GGX); B. Karis, "Real Shading in Unreal Engine 4", SIGGRAPH 2013 course notes
/// (the `k = alpha / 2` Smith-Schlick form, Schlick's Fresnel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gloss {
    /// Reflectance at normal incidence (Schlick's `F0`; 0.04 for plastic film).
    pub specular: f64,
    /// Perceptual roughness in (0, 1]; GGX `alpha = roughness^2`.
    pub roughness: f64,
}

impl Gloss {
    /// The specular term in grey levels per unit lamp irradiance `E_l` (module documentation),
    /// for unit vectors `n` (normal), `l` (to the light), `v` (to the camera).
    pub fn grey_per_irradiance(&self, n: &Vector3<f64>, l: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
        let (nl, nv) = (n.dot(l), n.dot(v));
        if nl <= 0.0 || nv <= 0.0 {
            return 0.0;
        }
        let h = (l + v).normalize();
        let a2 = self.roughness.powi(4);
        let d = ggx_d(n.dot(&h).max(0.0), a2);
        let k = 0.5 * self.roughness * self.roughness;
        let g1 = |x: f64| x / (x * (1.0 - k) + k);
        let f = self.specular + (1.0 - self.specular) * (1.0 - v.dot(&h).max(0.0)).powi(5);
        std::f64::consts::PI * 255.0 * d * g1(nl) * g1(nv) * f / (4.0 * nv)
    }
}

/// GGX's normal distribution `D(h)` at `n . h`, `a2 = alpha^2` (Walter et al. 2007, eq. 33).
fn ggx_d(nh: f64, a2: f64) -> f64 {
    a2 / (std::f64::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// GGX's D is a distribution of microfacet normals: its projected area integrates to one over
    /// the hemisphere, `int D(h) (n . h) dw = 1` (Walter et al. 2007, eq. 4), for any roughness.
    #[test]
    fn ggx_normals_project_to_unit_area() {
        for alpha in [0.05f64, 0.2, 0.6, 1.0] {
            let n = 200_000;
            let dt = std::f64::consts::FRAC_PI_2 / n as f64;
            let integral: f64 = (0..n)
                .map(|i| {
                    let t = (i as f64 + 0.5) * dt;
                    ggx_d(t.cos(), alpha * alpha) * t.cos() * t.sin() * dt * std::f64::consts::TAU
                })
                .sum();
            assert!((integral - 1.0).abs() < 1e-4, "alpha {alpha}: {integral}");
        }
    }
}
