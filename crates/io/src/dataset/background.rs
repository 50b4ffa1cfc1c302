//! A dataset's `[background]` (as in scene files, [`synthcam_scene::file::background`]), drawn
//! per image: one image of a `folder`, or a procedural image with a fresh seed per image, and a
//! yaw from `yaw_deg`, all from a stream seeded by (dataset seed, k) (so an image's background,
//! like its pose, depends only on them).

use std::sync::Arc;

use nalgebra::{Isometry3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{MeshLibrary, SpecError};
use synthcam_core::mesh::Texture;
use synthcam_scene::background::{clutter, Background, Placement};
use synthcam_scene::file::background::BackgroundSpec;

/// The images a dataset's background draws from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    /// One image for every frame (`image`), or one of a folder's per frame.
    Images(Vec<Arc<Texture>>),
    /// A procedural image per frame of this size.
    Clutter([u32; 2]),
}

/// A dataset's background, its images loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetBackground {
    spec: BackgroundSpec,
    source: Source,
    yaw_deg: Option<[f64; 2]>,
}

fn invalid(field: &str, reason: impl Into<String>) -> SpecError {
    SpecError::InvalidField { field: format!("background.{field}"), reason: reason.into() }
}

/// The image files of `dir` (PNG, JPEG, TIFF, BMP, WebP), in name order.
fn image_files(dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, SpecError> {
    let entries = std::fs::read_dir(dir).map_err(|e| invalid("folder", format!("{}: {e}", dir.display())))?;
    let mut files: Vec<_> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension()
                .and_then(|x| x.to_str())
                .is_some_and(|x| ["png", "jpg", "jpeg", "tif", "tiff", "bmp", "webp"].contains(&x.to_ascii_lowercase().as_str()))
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(invalid("folder", format!("{} holds no image (png, jpg, tif, bmp, webp)", dir.display())));
    }
    Ok(files)
}

impl DatasetBackground {
    /// Load the spec's image, folder or procedure (paths resolved by `files`) and check its
    /// placement.
    ///
    /// # Errors
    /// [`SpecError::InvalidField`] for a bad table, an empty folder or an image that does not
    /// load.
    pub fn load(spec: &BackgroundSpec, files: &MeshLibrary) -> Result<Self, SpecError> {
        let source = match (&spec.folder, &spec.image, &spec.procedural) {
            (Some(dir), None, None) => {
                let images = image_files(&files.resolve(dir))?
                    .iter()
                    .map(|p| files.image(&p.to_string_lossy()).map_err(|e| invalid("folder", e.to_string())))
                    .collect::<Result<Vec<_>, _>>()?;
                Source::Images(images)
            }
            (Some(_), ..) => return Err(invalid("folder", "give one of `folder`, `image` and `procedural`")),
            (None, None, Some(p)) if p == "clutter" => Source::Clutter(spec.clutter_size()?),
            _ => Source::Images(vec![spec.texture(files)?]),
        };
        if let Some([lo, hi]) = spec.yaw_deg {
            if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                return Err(invalid("yaw_deg", format!("must be a finite range [lo, hi], got [{lo}, {hi}]")));
            }
        }
        let placement = BackgroundSpec { folder: None, yaw_deg: None, ..spec.clone() };
        // The placement's checks, on a one-texel image (a procedural one is drawn per frame).
        let probe = Arc::new(Texture { width: 1, height: 1, texels: vec![0.0] });
        placement.placed(probe, &Isometry3::identity(), &Isometry3::identity()).map_err(|e| invalid("", e.to_string()))?;
        Ok(Self { spec: placement, source, yaw_deg: spec.yaw_deg })
    }

    /// Frame k's background (the target at `cam_from_target`, for `frame = "target"`).
    ///
    /// # Errors
    /// An invalid placement ([`BackgroundSpec::placed`]).
    pub fn for_image(&self, seed: u64, k: u64, cam_from_target: &Isometry3<f64>) -> Result<Background, synthcam_scene::SceneError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ k.wrapping_mul(0xd1b5_4a32_d192_ed03) ^ 0x6261_636b);
        let texture = match &self.source {
            Source::Images(list) => list[rng.random_range(0..list.len())].clone(),
            Source::Clutter([w, h]) => Arc::new(clutter(rng.random(), *w, *h)),
        };
        let mut bg = self.spec.placed(texture, &Isometry3::identity(), cam_from_target)?;
        if let Some([lo, hi]) = self.yaw_deg {
            let yaw = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), if hi > lo { rng.random_range(lo..=hi) } else { lo }.to_radians());
            bg.placement = match bg.placement {
                Placement::Panorama { cam_from_pano } => Placement::Panorama { cam_from_pano: yaw * cam_from_pano },
                Placement::Plane { cam_from_plane, size_m } => {
                    Placement::Plane { cam_from_plane: Isometry3::from_parts(nalgebra::Translation3::identity(), yaw) * cam_from_plane, size_m }
                }
            };
        }
        Ok(bg)
    }
}
