//! Rectangular area lights (`[[light]] kind = "area"`): a uniform Lambertian emitter of size
//! `w x h` metres whose frame (`position_m`, `rvec` in the light's `frame`) has the rectangle in
//! its x-y plane, centred, emitting towards its +z. `intensity` is the irradiance at 1 m on the
//! axis on a surface facing it, the point light's unit: the emitter's radiance is
//! `L = intensity / (w h)`, so a small area light shines as a point light whose intensity falls
//! off with the cosine of the emission angle.
//!
//! The irradiance a surface point `x` with normal `n` receives is `L` times the projected solid
//! angle of the part of the rectangle above `x`'s horizon, in closed form (Lambert's polygon
//! formula): with the polygon's vertices `v_i` relative to `x` (clipped to `n . v >= 0`),
//!
//! `E = L / 2 |sum_i theta_i n . (v_i x v_i+1) / |v_i x v_i+1||`, `theta_i` the angle between
//! `v_i` and `v_i+1`.
//!
//! Exact, so a board under an area light is shaded exactly to the shading's variation across one
//! pixel (as under a point light). With objects, their soft shadow scales the light's term by the
//! visible share of the emitter, weighted by `cos_x cos_light / r^2`
//! ([`crate::shadow::visible_share`], the renderer integrates it per pixel: `shaders/objects.wgsl`).
//!
//! Reference: J. Lambert, *Photometria* (1760); J. Arvo, "Applications of irradiance tensors to
//! the simulation of non-Lambertian phenomena", SIGGRAPH 1995 (section 3, the polygon's vector
//! irradiance); D. Baum, H. Rushmeier, J. Winget, "Improving radiosity solutions through the use of
//! analytically determined form-factors", SIGGRAPH 1989.

use nalgebra::{Isometry3, Point3, Rotation3, Vector3};

use crate::lighting::LightFrame;
use crate::SceneError;

/// One rectangular area light (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AreaLight {
    /// The frame of `position_m` and `rvec`.
    pub frame: LightFrame,
    /// The rectangle's centre, metres.
    pub position_m: [f64; 3],
    /// Rodrigues vector turning the light's frame (rectangle in its x-y plane, emitting to +z).
    pub rvec: [f64; 3],
    /// Width (along the light's x) and height (y), metres.
    pub size_m: [f64; 2],
    /// Irradiance at 1 m on the axis, on a surface facing the light, grey levels per unit albedo.
    pub intensity: f64,
}

impl AreaLight {
    /// Check the values: finite position and turn, sizes > 0, intensity finite and >= 0.
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] naming the field.
    pub fn validate(&self) -> Result<(), SceneError> {
        let invalid = |field: &str, reason: String| SceneError::InvalidField { field: format!("light.{field}"), reason };
        if !self.position_m.iter().chain(&self.rvec).all(|v| v.is_finite()) {
            return Err(invalid("position_m", format!("position_m and rvec must be finite, got {:?} and {:?}", self.position_m, self.rvec)));
        }
        if !self.size_m.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(invalid("size_m", format!("must be two finite sizes > 0, got {:?}", self.size_m)));
        }
        if !(self.intensity >= 0.0) || !self.intensity.is_finite() {
            return Err(invalid("intensity", format!("must be finite and >= 0, got {}", self.intensity)));
        }
        Ok(())
    }

    /// The emitter's radiance `L = intensity / (w h)`.
    pub fn radiance(&self) -> f64 {
        self.intensity / (self.size_m[0] * self.size_m[1])
    }

    /// The rectangle in the camera frame: a corner and the two edges from it (width, height),
    /// ordered so that `u x v` points where the light emits.
    pub fn rectangle_in_camera(&self, cam_from_target: &Isometry3<f64>) -> Rectangle {
        let turn = Rotation3::new(Vector3::from(self.rvec));
        let (u, v) = (turn * Vector3::x() * self.size_m[0], turn * Vector3::y() * self.size_m[1]);
        let centre = Point3::from(self.position_m);
        let corner = centre - 0.5 * (u + v);
        let rect = Rectangle { corner, u, v };
        match self.frame {
            LightFrame::Camera => rect,
            LightFrame::Target => rect.moved(cam_from_target),
        }
    }
}

/// A light's rectangle: `corner`, `corner + u`, `corner + u + v`, `corner + v`; it emits towards
/// `u x v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rectangle {
    /// One corner.
    pub corner: Point3<f64>,
    /// The edge along the light's width.
    pub u: Vector3<f64>,
    /// The edge along its height.
    pub v: Vector3<f64>,
}

impl Rectangle {
    /// The projected solid angle of the rectangle seen from `x` on a surface of unit normal `n`
    /// (steradians; times the radiance: the irradiance): Lambert's formula on the part above the
    /// surface's horizon; 0 where `x` lies behind the emitter.
    pub fn projected_solid_angle(&self, x: &Point3<f64>, n: &Vector3<f64>) -> f64 {
        let quad = self.corners_from(x);
        if self.u.cross(&self.v).dot(&quad[0]) >= 0.0 {
            return 0.0; // behind (or in) the emitting plane
        }
        let clipped = clip_above(&quad, n);
        let k = clipped.len();
        let sum: f64 = (0..k)
            .map(|i| {
                let (a, b) = (clipped[i], clipped[(i + 1) % k]);
                let axb = a.cross(&b);
                let s = axb.norm();
                if s > 0.0 {
                    s.atan2(a.dot(&b)) * n.dot(&axb) / s
                } else {
                    0.0
                }
            })
            .sum();
        0.5 * sum.abs()
    }

    /// The rectangle's part on the side `n . (p - origin) >= 0` of a plane: the corners of that
    /// convex polygon (0, 3, 4 or 5 of them) in the rectangle's order. A receiver on that plane
    /// sees only this part, so the renderer clips once per frame (its shader's polygon).
    pub fn part_above(&self, origin: &Point3<f64>, n: &Vector3<f64>) -> Vec<Point3<f64>> {
        clip_above(&self.corners_from(origin), n).into_iter().map(|v| origin + v).collect()
    }

    /// The four corners relative to `origin`, in order.
    fn corners_from(&self, origin: &Point3<f64>) -> [Vector3<f64>; 4] {
        let c = self.corner - origin;
        [c, c + self.u, c + self.u + self.v, c + self.v]
    }

    /// The same rectangle after the rigid motion `to_from`.
    pub fn moved(&self, to_from: &Isometry3<f64>) -> Rectangle {
        Rectangle { corner: to_from * self.corner, u: to_from.rotation * self.u, v: to_from.rotation * self.v }
    }

    /// The point at `(s, t)` in `[0, 1]^2` of the rectangle.
    pub fn at(&self, s: f64, t: f64) -> Point3<f64> {
        self.corner + s * self.u + t * self.v
    }

    /// The weight `cos_x cos_light / r^2` of the emitter's point `p` seen from `x` (normal `n`):
    /// its share of the irradiance per unit area; 0 below the horizon or behind the emitter.
    pub fn weight(&self, x: &Point3<f64>, n: &Vector3<f64>, p: &Point3<f64>) -> f64 {
        let d = p - x;
        let r2 = d.norm_squared();
        let emit = self.u.cross(&self.v).normalize();
        let (cx, cl) = (n.dot(&d), -emit.dot(&d));
        if cx <= 0.0 || cl <= 0.0 || r2 == 0.0 {
            return 0.0;
        }
        cx * cl / (r2 * r2)
    }
}

/// The polygon `poly` (vertices relative to the receiving point) clipped to the half-space
/// `n . v >= 0` (Sutherland-Hodgman; a convex polygon stays convex).
fn clip_above(poly: &[Vector3<f64>], n: &Vector3<f64>) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (n.dot(&a), n.dot(&b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(rvec: [f64; 3], size_m: [f64; 2]) -> AreaLight {
        AreaLight { frame: LightFrame::Camera, position_m: [0.1, -0.2, 0.3], rvec, size_m, intensity: 2.0 }
    }

    /// The closed form against a brute-force integral of `cos_x cos_light / r^2` over the
    /// rectangle (midpoint rule, 800^2 cells), for points facing it, tilted, partly below the
    /// horizon (clipped) and behind it.
    #[test]
    fn lambert_formula_matches_the_integral_over_the_emitter() {
        let l = light([0.3, -0.2, 0.1], [0.4, 0.25]);
        let rect = l.rectangle_in_camera(&Isometry3::identity());
        let cases = [
            (Point3::new(0.0, 0.0, 1.2), Vector3::new(0.0, 0.0, -1.0)),
            (Point3::new(0.3, 0.1, 0.9), Vector3::new(0.2, -0.3, -1.0).normalize()),
            (Point3::new(0.05, -0.15, 0.55), Vector3::new(1.0, 0.2, -0.3).normalize()), // straddles the horizon
            (Point3::new(0.0, 0.0, -1.0), Vector3::new(0.0, 0.0, 1.0)),                 // behind the emitter
        ];
        let m = 800;
        for (x, n) in cases {
            let mut sum = 0.0;
            for i in 0..m {
                for j in 0..m {
                    let p = rect.at((i as f64 + 0.5) / m as f64, (j as f64 + 0.5) / m as f64);
                    sum += rect.weight(&x, &n, &p);
                }
            }
            let brute = sum * rect.u.cross(&rect.v).norm() / (m * m) as f64;
            let exact = rect.projected_solid_angle(&x, &n);
            assert!((exact - brute).abs() <= 1e-5 * brute.max(1e-3), "x {x:?}: formula {exact}, integral {brute}");
        }
    }

    /// Far away and facing the surface, an area light is its point light: `intensity / r^2`, to
    /// the finite size's second-order correction (`(size / r)^2`, below 1e-4 here).
    #[test]
    fn a_small_light_far_away_is_a_point_light() {
        let l = AreaLight { position_m: [0.0, 0.0, 0.0], ..light([0.0; 3], [0.01, 0.02]) };
        let rect = l.rectangle_in_camera(&Isometry3::identity());
        let e = l.radiance() * rect.projected_solid_angle(&Point3::new(0.0, 0.0, 3.0), &Vector3::new(0.0, 0.0, -1.0));
        assert!((e - l.intensity / 9.0).abs() < 1e-4 * e, "{e} vs {}", l.intensity / 9.0);
    }

    #[test]
    fn bad_values_are_refused_by_name() {
        let bad = [light([0.0; 3], [0.0, 1.0]), AreaLight { intensity: f64::NAN, ..light([0.0; 3], [1.0, 1.0]) }, light([f64::INFINITY, 0.0, 0.0], [1.0, 1.0])];
        let fields: Vec<String> = bad.iter().map(|l| l.validate().expect_err("refused").to_string()).collect();
        assert!(fields[0].contains("size_m") && fields[1].contains("intensity") && fields[2].contains("position_m"), "{fields:?}");
    }
}
