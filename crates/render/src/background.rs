//! The background pass (`shaders/background.wgsl`): a panorama or an image on a plane
//! ([`synthcam_scene::background`]) behind the target, mixed with it by the target's exact
//! coverage of each pixel.
//!
//! The target passes are linear in the target's background grey `B`: a pixel the sheet covers
//! by `c` shows `A + (1 - c) B`. So the frame is rendered as before (with `B`), then the tiles the
//! sheet's outline may cross are rendered again with every grey 0 and the background 1, which
//! gives `1 - c` there (elsewhere it is 0 or 1 by the tile's place: [`super::flat::sheet_cover`]),
//! and every pixel with `1 - c > 0` takes `(1 - c) (G - B)` more, `G` the background's mean over
//! the pixel's footprint. The objects' passes follow and see the background through `bg_point`.

use std::sync::Arc;

use super::bg_tiles::{flat_background_tiles, MinMaxPyramid};
use super::buffers::{Buffers, STORAGE_DST};
use super::flat::Cover;
use super::gpu_scene::{GpuScene, PassKind};
use super::tiles::{TileCornerRays, TILE_PX};
use super::uniforms::Params;
use super::{RenderError, Renderer};
use synthcam_core::mesh::Texture;
use synthcam_scene::background::Placement;
use synthcam_scene::Scene;

/// The background's uniforms (`Params::bg*`; all 0 without one).
pub(super) fn background_params(p: &mut Params, scene: &Scene) {
    let Some(bg) = &scene.background else { return };
    let (kind, bg_from_cam, size) = match bg.placement {
        Placement::Panorama { cam_from_pano } => (1.0, nalgebra::Isometry3::from_parts(nalgebra::Translation3::identity(), cam_from_pano.inverse()), [0.0; 2]),
        Placement::Plane { cam_from_plane, size_m } => (2.0, cam_from_plane.inverse(), size_m),
    };
    let r = bg_from_cam.rotation.to_rotation_matrix();
    let t = bg_from_cam.translation.vector;
    p.bg = [kind, bg.texture.width as f32, bg.texture.height as f32, 0.0];
    for (row, out) in [&mut p.bg0, &mut p.bg1, &mut p.bg2].into_iter().enumerate() {
        *out = [r[(row, 0)] as f32, r[(row, 1)] as f32, r[(row, 2)] as f32, t[row] as f32];
    }
    p.bg_size = [size[0] as f32, size[1] as f32, 0.0, 0.0];
}

/// The image's rows as `bg_data` holds them: the texels, then per row their prefix sums.
fn background_rows(texture: &Texture) -> Vec<f32> {
    let mut rows = texture.texels.clone();
    rows.extend(texture.row_prefix_sums());
    rows
}

impl Renderer {
    /// Write the background's image into its buffer unless it holds it already (binding 9: a
    /// placeholder without a background).
    pub(super) fn upload_background(&self, bufs: &mut Buffers, scene: &Scene) -> Result<(), RenderError> {
        let device = &self.context().device;
        let Some(bg) = &scene.background else {
            bufs.bg.get(device, "background", 16, STORAGE_DST);
            return Ok(());
        };
        let bytes = (bg.texture.texels.len() * 2 + bg.texture.height as usize) as u64 * 4;
        let max = device.limits().max_storage_buffer_binding_size;
        if bytes > max {
            return Err(RenderError::TooLarge { width: bg.texture.width, height: bg.texture.height, max_bytes: max });
        }
        if bufs.bg_texture.as_ref().is_some_and(|t| Arc::ptr_eq(t, &bg.texture)) && bufs.bg.size() >= bytes {
            return Ok(());
        }
        bg.validate_texels()?;
        let buffer = bufs.bg.get(device, "background", bytes, STORAGE_DST);
        self.context().queue.write_buffer(buffer, 0, bytemuck::cast_slice(&background_rows(&bg.texture)));
        bufs.bg_texture = Some(bg.texture.clone());
        bufs.bg_pyramid = Some(Arc::new(MinMaxPyramid::new(&bg.texture)));
        Ok(())
    }

    /// Mix `scene`'s background into the target's image `img` (rendered with the target's
    /// background grey): the sheet's coverage where its outline may pass, then the background
    /// pass over every pixel the sheet does not cover wholly.
    pub(super) fn compose_background(
        &self,
        bufs: &mut Buffers,
        gs: &GpuScene,
        scene: &Scene,
        grid: &TileCornerRays,
        img: &mut [f32],
    ) -> Result<(), RenderError> {
        let Some(bg) = &scene.background else { return Ok(()) };
        let t0 = std::time::Instant::now();
        let w = scene.camera.size.width;
        let tiles_x = gs.params.tiles[0];
        let view_set = synthcam_scene::views::view_set(scene);
        let cover = super::flat::sheet_cover(scene, grid, (tiles_x, gs.params.tiles[1]), &view_set);
        let open = self.open_fraction(bufs, gs, scene, &cover)?;
        let pyramid = bufs.bg_pyramid.clone().ok_or_else(|| RenderError::Device("the background was not uploaded".into()))?;
        let flat = flat_background_tiles(bg, &pyramid, grid, (tiles_x, gs.params.tiles[1]), &cover);
        let grey = scene.target.background() as f32;
        let h = scene.camera.size.height;
        let mut work = Vec::new();
        for (t, _) in cover.iter().enumerate().filter(|(_, c)| matches!(c, Cover::Outside | Cover::Mixed)) {
            let (x0, y0) = ((t as u32 % tiles_x) * TILE_PX, (t as u32 / tiles_x) * TILE_PX);
            for y in y0..(y0 + TILE_PX).min(h) {
                for x in x0..(x0 + TILE_PX).min(w) {
                    let i = (y * w + x) as usize;
                    match (open[i] > 0.0, flat[t]) {
                        (true, Some(v)) => img[i] += open[i] * (v - grey),
                        (true, None) => work.push(x | (y << 16)),
                        (false, _) => {}
                    }
                }
            }
        }
        log::debug!(
            "background: {} pixels, {} tiles under the sheet's outline, {:.1} ms to the background pass",
            work.len(),
            cover.iter().filter(|c| **c == Cover::Mixed).count(),
            t0.elapsed().as_secs_f64() * 1e3
        );
        if work.is_empty() {
            return Ok(());
        }
        let (vals, _) = self.run_pass(bufs, gs, PassKind::Background, true, &work)?;
        for (packed, v) in work.iter().zip(vals) {
            let i = (packed >> 16) as usize * w as usize + (packed & 0xffff) as usize;
            img[i] += open[i] * (v - grey);
        }
        Ok(())
    }

    /// `1 - c` per pixel, `c` the sheet's coverage: the target passes with every grey 0 and the
    /// background 1 (no lamp, no gloss) over the tiles the outline may cross; 0 under the sheet,
    /// 1 beside it.
    fn open_fraction(&self, bufs: &mut Buffers, gs: &GpuScene, scene: &Scene, cover: &[Cover]) -> Result<Vec<f32>, RenderError> {
        let mut open = gs.clone();
        open.params.grey = [0.0, 0.0, 0.0, 1.0];
        open.params.shade = [0.0; 4];
        open.tile_flat = cover
            .iter()
            .map(|c| match c {
                Cover::Inside => 0.0,
                Cover::Outside | Cover::Beyond => 1.0,
                Cover::Mixed => -1.0,
            })
            .collect();
        self.target_image(bufs, &open, scene)
    }
}
