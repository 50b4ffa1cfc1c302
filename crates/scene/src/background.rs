//! Backgrounds (`[background]`): what a ray that misses the target and every object sees,
//! instead of the target's uniform background grey. Two placements:
//!
//! - **Panorama**: an equirectangular image around the camera (it covers a fisheye's whole field).
//!   In the panorama's frame (x right, y down, z ahead, as a camera's), a direction `e` has
//!   longitude `lon = atan2(e.x, e.z)` and latitude `lat = atan2(e.y, |e.xz|)` (down positive), and
//!   texel coordinates `s = (lon / 2 pi + 0.5) W`, `t = (lat / pi + 0.5) H`: the image's centre is
//!   straight ahead, its top row straight up, its left and right edges straight behind.
//!   `cam_from_pano` turns it.
//! - **Plane**: an image on a plane at `cam_from_plane` (the image in the plane's z = 0, centred on
//!   its origin, x right, y down, `size_m` wide and high); rays that miss it see the target's
//!   background grey.
//!
//! The background is an environment: drawn behind the target and the objects wherever they do
//! not cover a pixel, whatever its depth, and never lit (as the target's background grey). The
//! renderer box-filters it over each pixel's footprint along the same per-pixel inverse-lens ray
//! as the target (`shaders/background.wgsl`), so it is distorted exactly as the board is, and
//! mixes it with the target by the target's exact coverage of the pixel.
//!
//! Reference: the equirectangular (plate carree) projection as in P. Debevec, *Rendering
//! synthetic objects into real scenes* (SIGGRAPH 1998) and every HDRI library (Poly Haven).

use std::f64::consts::PI;
use std::sync::Arc;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam_core::mesh::Texture;

use crate::SceneError;

/// Where a background image lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Placement {
    /// An equirectangular panorama at infinity, turned by `cam_from_pano`.
    Panorama {
        /// The panorama's frame in the camera's.
        cam_from_pano: UnitQuaternion<f64>,
    },
    /// An image on a plane.
    Plane {
        /// The plane's frame (the image in its z = 0, centred, x right, y down).
        cam_from_plane: Isometry3<f64>,
        /// The image's width and height on the plane, metres.
        size_m: [f64; 2],
    },
}

/// A background image and its placement.
#[derive(Debug, Clone, PartialEq)]
pub struct Background {
    /// The image (grey levels 0..255, piecewise constant over its texels).
    pub texture: Arc<Texture>,
    /// Where it lies.
    pub placement: Placement,
}

impl Background {
    /// An equirectangular panorama turned by `cam_from_pano`.
    pub fn panorama(texture: Arc<Texture>, cam_from_pano: UnitQuaternion<f64>) -> Self {
        Self { texture, placement: Placement::Panorama { cam_from_pano } }
    }

    /// An image `size_m` wide and high on the plane at `cam_from_plane`.
    pub fn plane(texture: Arc<Texture>, cam_from_plane: Isometry3<f64>, size_m: [f64; 2]) -> Self {
        Self { texture, placement: Placement::Plane { cam_from_plane, size_m } }
    }

    /// The same background seen from another camera, `new_from_old` mapping this one's camera
    /// frame into it (a rig's camera: `cam_from_cam0`; a panorama at infinity only turns).
    pub fn seen_from(&self, new_from_old: &Isometry3<f64>) -> Self {
        let placement = match self.placement {
            Placement::Panorama { cam_from_pano } => Placement::Panorama { cam_from_pano: new_from_old.rotation * cam_from_pano },
            Placement::Plane { cam_from_plane, size_m } => Placement::Plane { cam_from_plane: new_from_old * cam_from_plane, size_m },
        };
        Self { texture: self.texture.clone(), placement }
    }

    /// Check the image and the placement: [`Background::validate_placement`] and
    /// [`Background::validate_texels`].
    ///
    /// # Errors
    /// As those two.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.validate_placement()?;
        self.validate_texels()
    }

    /// Every texel a grey level: one pass over the image, which the renderer runs once per image
    /// it uploads ([`crate::Scene::validate`], run on every frame, does not; images decoded from
    /// files and the procedural clutter are grey levels by construction).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] (`background.image`) for a texel that is not a finite level in
    /// 0..=65535.
    pub fn validate_texels(&self) -> Result<(), SceneError> {
        // A branch-free pass first (NaN fails both tests).
        let level = |v: &f32| *v >= 0.0 && *v <= 65535.0;
        let t = &self.texture;
        if !t.texels.iter().fold(true, |ok, v| ok & level(v)) {
            let v = t.texels.iter().find(|v| !level(v)).copied().unwrap_or(f32::NAN);
            return Err(SceneError::InvalidField { field: "background.image".into(), reason: format!("texel {v} is not a grey level in 0..=65535") });
        }
        Ok(())
    }

    /// The image's size and the placement (no pass over the texels).
    ///
    /// # Errors
    /// [`SceneError::InvalidField`] (`background.*`) for an empty or oversized image, or a
    /// non-finite or non-positive size or pose.
    pub fn validate_placement(&self) -> Result<(), SceneError> {
        let bad = |field: &str, reason: String| Err(SceneError::InvalidField { field: format!("background.{field}"), reason });
        let t = &self.texture;
        if t.width == 0 || t.height == 0 || t.texels.len() != t.width as usize * t.height as usize {
            return bad("image", format!("{} x {} texels with {} values: needs at least one texel and one value each", t.width, t.height, t.texels.len()));
        }
        if t.width > 16384 || t.height > 16384 {
            return bad("image", format!("{} x {} texels exceeds 16384", t.width, t.height));
        }
        match self.placement {
            Placement::Panorama { cam_from_pano } if !cam_from_pano.coords.iter().all(|v| v.is_finite()) => bad("rvec", "is not finite".into()),
            Placement::Plane { cam_from_plane, size_m } => {
                if !size_m.iter().all(|v| v.is_finite() && *v > 0.0) {
                    return bad("size_m", format!("must be finite and > 0, got {size_m:?}"));
                }
                let pose = cam_from_plane.rotation.coords.iter().chain(cam_from_plane.translation.vector.iter());
                if !pose.into_iter().all(|v| v.is_finite()) {
                    return bad("t_m", "the plane's pose is not finite".into());
                }
                Ok(())
            }
            Placement::Panorama { .. } => Ok(()),
        }
    }

    /// Texel coordinates `(s, t)` seen along the camera ray `d_cam` (any length), or `None` where
    /// it misses the image (a plane behind the camera, or the ray beside the image).
    pub fn texel_along(&self, d_cam: &Vector3<f64>) -> Option<[f64; 2]> {
        let (w, h) = (f64::from(self.texture.width), f64::from(self.texture.height));
        match self.placement {
            Placement::Panorama { cam_from_pano } => Some(equirect_texel(&(cam_from_pano.inverse() * d_cam), w, h)),
            Placement::Plane { cam_from_plane, size_m } => {
                let plane_from_cam = cam_from_plane.inverse();
                let (o, e) = (plane_from_cam.translation.vector, plane_from_cam.rotation * d_cam);
                let t = -o.z / e.z;
                let (x, y) = (o.x + t * e.x, o.y + t * e.y);
                let st = [(x / size_m[0] + 0.5) * w, (y / size_m[1] + 0.5) * h];
                (t > 0.0 && t.is_finite() && (0.0..=w).contains(&st[0]) && (0.0..=h).contains(&st[1])).then_some(st)
            }
        }
    }

    /// The texel seen along `d_cam` (a point sample), or `None` where the ray misses the image.
    pub fn value_along(&self, d_cam: &Vector3<f64>) -> Option<f64> {
        self.texel_along(d_cam).map(|st| self.texture.at(st))
    }

    /// The camera-frame depth (z, metres) of the background along `d_cam`: the plane's where the
    /// ray meets the image, infinity for a panorama, `None` where it misses.
    pub fn depth_along(&self, d_cam: &Vector3<f64>) -> Option<f64> {
        let _ = self.texel_along(d_cam)?;
        match self.placement {
            Placement::Panorama { .. } => Some(f64::INFINITY),
            Placement::Plane { cam_from_plane, .. } => {
                let n = cam_from_plane.rotation * Vector3::z();
                let t = n.dot(&cam_from_plane.translation.vector) / n.dot(d_cam);
                Some(t * d_cam.z)
            }
        }
    }
}

/// Backgrounds are drawn behind planar targets (the S-path's sphere is not mixed with one yet).
///
/// # Errors
/// [`SceneError::InvalidField`] (`background`) for the S-path.
pub fn check_target(target: &synthcam_core::target::Target) -> Result<(), SceneError> {
    if target.is_planar() {
        return Ok(());
    }
    Err(SceneError::InvalidField {
        field: "background".into(),
        reason: "backgrounds are drawn behind planar targets (chessboard, dot grid, ChArUco, AprilGrid); the S-path is not supported yet".into(),
    })
}

/// Texel coordinates of direction `e` (panorama frame) in a `w x h` equirectangular image.
pub fn equirect_texel(e: &Vector3<f64>, w: f64, h: f64) -> [f64; 2] {
    let lon = e.x.atan2(e.z);
    let lat = e.y.atan2(e.x.hypot(e.z));
    [(lon / (2.0 * PI) + 0.5) * w, (lat / PI + 0.5) * h]
}

/// A procedural clutter image, `width x height` texels, drawn from `seed`: a wall and a floor,
/// then rectangles (posters, monitors, shelves, with frames), stripes of books, discs
/// and a few thin lines at random grey levels, with edges of every contrast and many false
/// corners (what detectors meet behind real boards). Wraps horizontally (a panorama has no
/// seam). Made here, no outside image: the same seed gives the same image on every machine.
pub fn clutter(seed: u64, width: u32, height: u32) -> Texture {
    let (w, h) = (width.max(1) as usize, height.max(1) as usize);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (wall, floor) = (rng.random_range(60.0..200.0f32), rng.random_range(40.0..180.0f32));
    let horizon = (rng.random_range(0.55..0.75f32) * h as f32) as usize;
    let mut px: Vec<f32> = (0..w * h).map(|i| if i / w < horizon { wall } else { floor }).collect();
    let mut fill = |x0: f32, y0: f32, x1: f32, y1: f32, grey: f32, disc: bool| {
        let (cx, cy, rx, ry) = (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (x1 - x0), 0.5 * (y1 - y0));
        for y in (y0.max(0.0) as usize)..(y1.min(h as f32) as usize) {
            for xi in (x0 as isize)..(x1 as isize) {
                let inside = !disc || ((xi as f32 + 0.5 - cx) / rx).powi(2) + ((y as f32 + 0.5 - cy) / ry).powi(2) <= 1.0;
                if inside {
                    px[y * w + xi.rem_euclid(w as isize) as usize] = grey;
                }
            }
        }
    };
    let (wf, hf) = (w as f32, h as f32);
    for _ in 0..rng.random_range(70..110) {
        let (x0, y0) = (rng.random_range(0.0..wf), rng.random_range(0.0..hf));
        let (rw, rh) = (rng.random_range(0.01..0.12) * wf, rng.random_range(0.02..0.25) * hf);
        let (frame, inner) = (rng.random_range(0.0..255.0f32), rng.random_range(0.0..255.0f32));
        let disc = rng.random_bool(0.2);
        fill(x0, y0, x0 + rw, y0 + rh, frame, disc);
        let b = rng.random_range(0.05..0.2) * rw.min(rh);
        fill(x0 + b, y0 + b, x0 + rw - b, y0 + rh - b, inner, disc);
        if rng.random_bool(0.3) {
            // A shelf of books: vertical stripes.
            let mut x = x0 + b;
            while x < x0 + rw - b {
                let sw = rng.random_range(0.004..0.012) * wf;
                fill(x, y0 + b + 0.2 * rh, x + sw, y0 + rh - b, rng.random_range(10.0..245.0), false);
                x += sw;
            }
        }
    }
    Texture { width: w as u32, height: h as u32, texels: px }
}
