//! Exact CPU ray caster: the f64 twin of the shaders (`shaders/*.wgsl`).
//!
//! A sample at pixel position `q_px` is unprojected exactly (Newton inversion of the distortion,
//! [`synthcam_core::camera::Distortion::undistort`]), the ray is intersected with the exact target geometry
//! (plane z = 0, or the sphere and the beads / painted caps of the S-path) and shaded with the
//! target's piecewise-constant grey levels. Samples whose distortion cannot be inverted (beyond the
//! fold of the lens model) and rays that miss the target see the background.

use nalgebra::{Isometry3, Point2, Point3, Vector3};

use super::Scene;
use synthcam_core::target::{DotStyle, Target};

/// What one ray sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Grey level.
    pub intensity: f64,
    /// Index of the dot the ray hits, if it hits one.
    pub feature: Option<usize>,
}

/// A sphere in camera coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereCam {
    /// Centre, camera frame, metres.
    pub centre: Point3<f64>,
    /// Radius, metres.
    pub radius: f64,
}

impl SphereCam {
    /// Smallest positive ray parameter `t` with `|t d - centre| = radius` (ray from the camera centre).
    pub fn intersect(&self, d: &Vector3<f64>) -> Option<f64> {
        let a = d.dot(d);
        let b = d.dot(&self.centre.coords);
        let c = self.centre.coords.norm_squared() - self.radius * self.radius;
        let disc = b * b - a * c;
        if disc < 0.0 || a <= 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let t0 = (b - s) / a;
        let t1 = (b + s) / a;
        if t0 > 0.0 {
            Some(t0)
        } else if t1 > 0.0 {
            Some(t1)
        } else {
            None
        }
    }
}

/// Precomputed ray caster for one scene.
#[derive(Debug, Clone)]
pub struct Tracer<'a> {
    scene: &'a Scene,
    target_from_cam: Isometry3<f64>,
    sphere: Option<SphereCam>,
    dots: Vec<SphereCam>,
    /// A warped board's warp (flat: the default).
    warp: synthcam_core::target::Warp,
    /// The light on lit objects.
    object_light: crate::shadow::ObjectLight,
}

impl<'a> Tracer<'a> {
    /// Prepare the scene's geometry in camera coordinates.
    pub fn new(scene: &'a Scene) -> Self {
        let target_from_cam = scene.cam_from_target.inverse();
        let (sphere, dots) = match &scene.target {
            Target::SPath(s) => {
                let sphere = SphereCam { centre: scene.cam_from_target * s.path.sphere_center_m, radius: s.path.sphere_radius_m };
                let dots = s.path.points_m.iter().enumerate().map(|(i, p)| SphereCam { centre: scene.cam_from_target * p, radius: s.dot_radius(i) }).collect();
                (Some(sphere), dots)
            }
            _ => (None, Vec::new()),
        };
        let object_light = crate::shadow::ObjectLight::of(scene);
        Self { scene, target_from_cam, sphere, dots, warp: scene.target.warp().unwrap_or_default(), object_light }
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        self.scene
    }

    /// The S-path sphere and dots in camera coordinates (empty for planar targets).
    pub fn spheres(&self) -> (Option<SphereCam>, &[SphereCam]) {
        (self.sphere, &self.dots)
    }

    /// What the sample at pixel position `q_px` sees.
    pub fn trace_px(&self, q_px: &Point2<f64>) -> Hit {
        self.trace_px_in(q_px, None)
    }

    /// What the ray from the camera centre along `d_cam` (camera frame) sees.
    pub fn trace_ray(&self, d_cam: &Vector3<f64>) -> Hit {
        self.trace_ray_among(d_cam, None)
    }

    /// What the sample at pixel position `q_px` sees when only the S-path dots `candidates` can
    /// be in front of it (the caller knows the others project elsewhere); other targets ignore
    /// `candidates`.
    pub fn trace_px_among(&self, q_px: &Point2<f64>, candidates: &[usize]) -> Hit {
        self.trace_px_in(q_px, Some(candidates))
    }

    /// What an object nearer than `t_max` along `t d_cam` shows, if one is.
    fn object_in_front(&self, d_cam: &Vector3<f64>, t_max: f64) -> Option<Hit> {
        let objects = &self.scene.objects;
        let h = super::objects::cast_objects(objects, d_cam, t_max)?;
        Some(Hit { intensity: self.object_light.object_value(objects, &h, d_cam), feature: None })
    }

    fn trace_px_in(&self, q_px: &Point2<f64>, candidates: Option<&[usize]>) -> Hit {
        match self.scene.camera.unproject_ray(q_px) {
            Ok(ray) => self.trace_ray_among(&ray, candidates),
            Err(_) => Hit { intensity: self.scene.target.background(), feature: None },
        }
    }

    fn trace_ray_among(&self, d_cam: &Vector3<f64>, candidates: Option<&[usize]>) -> Hit {
        let target = &self.scene.target;
        let background = Hit { intensity: target.background(), feature: None };
        match target {
            Target::Chessboard(_) | Target::DotGrid(_) | Target::Charuco(_) | Target::AprilGrid(_) => {
                let o = self.target_from_cam.translation.vector;
                let d = self.target_from_cam.rotation * d_cam;
                // A warped board's paraboloid (flat: the plane z = 0).
                let t = self.warp.intersect(&o, &d).unwrap_or(f64::NAN);
                if d.z == 0.0 || !(t > 0.0) || !t.is_finite() {
                    return self.object_in_front(d_cam, f64::INFINITY).unwrap_or(background);
                }
                let (x, y) = (o.x + t * d.x, o.y + t * d.y);
                if let Some(h) = self.object_in_front(d_cam, if target.on_sheet(x, y) { t } else { f64::INFINITY }) {
                    return h;
                }
                let intensity = target.plane_intensity(x, y).unwrap_or(background.intensity);
                let feature = match target {
                    Target::DotGrid(g) if intensity == g.dark => dot_grid_index(g, x, y),
                    _ => None,
                };
                Hit { intensity, feature }
            }
            Target::SPath(s) => {
                let Some(sphere) = self.sphere else { return background };
                let dn = d_cam.normalize();
                let t_sphere = sphere.intersect(&dn);
                match candidates {
                    Some(c) => self.s_path_hit(s, &dn, t_sphere, c.iter().copied()),
                    None => self.s_path_hit(s, &dn, t_sphere, 0..self.dots.len()),
                }
            }
        }
    }

    /// The S-path hit along the unit ray `dn` among dots `ids` (ascending).
    fn s_path_hit(&self, s: &synthcam_core::target::SPathDots, dn: &Vector3<f64>, t_sphere: Option<f64>, ids: impl Iterator<Item = usize>) -> Hit {
        let background = Hit { intensity: self.scene.target.background(), feature: None };
        match s.style {
            DotStyle::Bead => {
                let mut best: Option<(f64, usize)> = None;
                for i in ids {
                    let b = &self.dots[i];
                    // Cheap reject: distance from the ray to the bead centre.
                    let along = dn.dot(&b.centre.coords);
                    if along <= 0.0 || (b.centre.coords - dn * along).norm_squared() >= b.radius * b.radius {
                        continue;
                    }
                    if let Some(t) = b.intersect(dn) {
                        if best.is_none_or(|(tb, _)| t < tb) {
                            best = Some((t, i));
                        }
                    }
                }
                match (best, t_sphere) {
                    (Some((tb, i)), ts) if ts.is_none_or(|ts| tb <= ts) => Hit { intensity: s.dark, feature: Some(i) },
                    (_, Some(_)) => Hit { intensity: s.light, feature: None },
                    _ => background,
                }
            }
            DotStyle::Disc => {
                let Some(ts) = t_sphere else { return background };
                let h = dn * ts;
                for i in ids {
                    let c = &self.dots[i];
                    if (h - c.centre.coords).norm_squared() < c.radius * c.radius {
                        return Hit { intensity: s.dark, feature: Some(i) };
                    }
                }
                Hit { intensity: s.light, feature: None }
            }
        }
    }
}

/// Index (x slow, y fast) of the dot-grid disc containing (x, y), if any.
fn dot_grid_index(g: &synthcam_core::target::DotGrid, x: f64, y: f64) -> Option<usize> {
    let h = 0.5 * g.edge_m;
    let p = g.pitch_m();
    let last = f64::from(g.n - 1);
    let ix = ((x + h) / p).round().clamp(0.0, last);
    let iy = ((y + h) / p).round().clamp(0.0, last);
    let (dx, dy) = (x - (-h + p * ix), y - (-h + p * iy));
    (dx * dx + dy * dy < g.dot_radius_m * g.dot_radius_m).then_some(ix as usize * g.n as usize + iy as usize)
}

/// Conservative pixel bounding box `[u_min, v_min, u_max, v_max]` of dot `i` (a ball or cap of its
/// radius around its centre), from the projections of a cube that contains it, plus `margin_px`.
/// `None` when part of the cube is not in front of the camera.
pub fn dot_bbox_px(scene: &Scene, centre_target_m: &Point3<f64>, radius_m: f64, margin_px: f64) -> Option<[f64; 4]> {
    let c = scene.cam_from_target * centre_target_m;
    let r = radius_m * 1.05;
    let mut bb = [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY];
    for sx in [-1.0, 0.0, 1.0] {
        for sy in [-1.0, 0.0, 1.0] {
            for sz in [-1.0, 0.0, 1.0] {
                let p = c + Vector3::new(sx, sy, sz) * r;
                if p.z <= 1e-6 {
                    return None;
                }
                let q = scene.camera.project_unchecked(&p);
                bb = [bb[0].min(q.x), bb[1].min(q.y), bb[2].max(q.x), bb[3].max(q.y)];
            }
        }
    }
    bb.iter().all(|v| v.is_finite()).then_some([bb[0] - margin_px, bb[1] - margin_px, bb[2] + margin_px, bb[3] + margin_px])
}
