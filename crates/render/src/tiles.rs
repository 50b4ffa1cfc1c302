//! The tile grid the renderer works in: the tile size and the rays through the tile corners,
//! shared by the scene's GPU inputs (`gpu_scene`), the CPU's flat-tile classification (`flat`)
//! and the objects' tile lists.

use nalgebra::{Point2, Vector3};
use rayon::prelude::*;
use synthcam_core::camera::{CameraModel, Lens};

/// Tile edge, pixels. Fixed at 8: the shader's coarse pass runs one 8 x 8 workgroup per tile.
pub const TILE_PX: u32 = 8;

/// Rays (camera frame, [`CameraModel::unproject_ray`]) through the corners of the tile grid, `(tiles_x + 1) x (tiles_y + 1)`,
/// row-major; `None` where the distortion cannot be inverted. Depends only on the camera, so a
/// renderer computes it once per camera (like an undistortion map).
#[derive(Debug, Clone, PartialEq)]
pub struct TileCornerRays {
    /// The camera the rays belong to.
    pub camera: CameraModel,
    rays: Vec<Option<Vector3<f64>>>,
    /// [`super::bend::split_radii`] of the camera.
    pub(crate) split_radii: [f64; 2],
}

impl TileCornerRays {
    /// Unproject every tile corner of `camera`'s image.
    pub fn new(camera: &CameraModel) -> Self {
        let tx = camera.size.width.div_ceil(TILE_PX) + 1;
        let ty = camera.size.height.div_ceil(TILE_PX) + 1;
        let (w, h) = (f64::from(camera.size.width), f64::from(camera.size.height));
        let (rays, split_radii) = rayon::join(
            || {
                (0..tx * ty)
                    .into_par_iter()
                    .map(|k| {
                        let x = (f64::from((k % tx) * TILE_PX) - 0.5).min(w - 0.5);
                        let y = (f64::from((k / tx) * TILE_PX) - 0.5).min(h - 0.5);
                        camera.unproject_ray(&Point2::new(x, y)).ok()
                    })
                    .collect()
            },
            || super::bend::split_radii(camera),
        );
        Self { camera: *camera, rays, split_radii }
    }

    /// The four corner rays of tile (tx, ty), or `None` if one is missing.
    pub(super) fn tile(&self, tx: u32, ty: u32) -> Option<[Vector3<f64>; 4]> {
        let c = self.corners(tx, ty);
        Some([c[0]?, c[1]?, c[2]?, c[3]?])
    }

    fn corners(&self, tx: u32, ty: u32) -> [Option<Vector3<f64>>; 4] {
        let stride = self.camera.size.width.div_ceil(TILE_PX) + 1;
        let at = |x: u32, y: u32| self.rays.get((y * stride + x) as usize).copied().flatten();
        [at(tx, ty), at(tx + 1, ty), at(tx + 1, ty + 1), at(tx, ty + 1)]
    }

    /// Whether tile (tx, ty) lies wholly outside the lens's valid region: no corner has a ray and
    /// the region is an ellipse in the image (fisheye, Double Sphere: a disc of distorted radii),
    /// convex and hundreds of pixels across, so it cannot reach a pixel centre of the tile (half a
    /// pixel inside its edges) between corners outside it.
    pub(super) fn beyond_lens(&self, tx: u32, ty: u32) -> bool {
        matches!(self.camera.lens, Lens::Fisheye(_) | Lens::DoubleSphere(_)) && self.corners(tx, ty).iter().all(Option::is_none)
    }
}
