//! The objects' passes (`shaders/objects.wgsl`), after the target's: a coarse pass over the
//! tiles an object may cover (pixel-corner rays; each pixel keeps the target's value, takes the
//! object's, or is flagged) and a fine pass of `samples^2` exact rays per flagged pixel.

use std::sync::Arc;

use super::buffers::{Buffers, STORAGE_DST};
use super::gpu_scene::{GpuScene, PassKind};
use super::objects::{instance_rows, object_params, MeshRows};
use super::soft_lattice::{near_sheet, Lattice};
use super::tiles::{TileCornerRays, TILE_PX};
use super::{RenderError, Renderer};
use synthcam_scene::Scene;

impl Renderer {
    /// Lay out (or reuse) the meshes' rows, write them when the buffer does not hold them yet,
    /// then this frame's instances; set the object uniforms of `gs`.
    pub(super) fn upload_objects(&self, bufs: &mut Buffers, gs: &mut GpuScene, scene: &Scene) -> Result<(), RenderError> {
        let meshes = {
            let mut cache = self.mesh_rows.lock().map_err(|_| RenderError::Device("renderer mutex poisoned".into()))?;
            match cache.as_ref() {
                Some(m) if m.serves(scene) => m.clone(),
                _ => {
                    let m = Arc::new(MeshRows::new(scene)?);
                    *cache = Some(m.clone());
                    m
                }
            }
        };
        let instances = instance_rows(scene, &meshes);
        let (device, queue) = (&self.context().device, &self.context().queue);
        // Under an area light, room behind the instances for the soft-shadow lattice.
        let lattice = if gs.params.soft_shadows() { Lattice::rows(gs.params.tiles[0], gs.params.tiles[1]) } else { 0 };
        let bytes = ((meshes.rows.len() + instances.len() + lattice) * 16) as u64;
        let max = device.limits().max_storage_buffer_binding_size;
        if bytes > max {
            return Err(RenderError::TooLarge { width: scene.camera.size.width, height: scene.camera.size.height, max_bytes: max });
        }
        let before = bufs.objs.size();
        let buffer = bufs.objs.get(device, "objs", bytes, STORAGE_DST);
        let fresh = buffer.size() != before || bufs.objs_meshes.as_ref().is_none_or(|m| !Arc::ptr_eq(m, &meshes));
        if fresh {
            queue.write_buffer(buffer, 0, bytemuck::cast_slice(&meshes.rows));
            bufs.objs_meshes = Some(meshes.clone());
        }
        queue.write_buffer(buffer, (meshes.rows.len() * 16) as u64, bytemuck::cast_slice(&instances));
        object_params(&mut gs.params, scene, meshes.rows.len());
        Ok(())
    }

    /// Run the objects' passes over `tiles` and write their pixels into `img` (a target pixel in
    /// an object's shadow: the target passes' value times the shadowed-over-lit ratio the coarse
    /// pass returns for it); `grid`, the tiles' corner rays, places the soft-shadow lattice.
    pub(super) fn render_objects(&self, bufs: &mut Buffers, gs: &GpuScene, tiles: &[u32], grid: &TileCornerRays, img: &mut [f32]) -> Result<(), RenderError> {
        if tiles.is_empty() {
            return Ok(());
        }
        let (w, h) = (gs.params.size[0] as usize, gs.params.size[1] as usize);
        let soft = gs.params.soft_shadows();
        let mut params = gs.params;
        if soft {
            params.soft_v[3] = self.soft_lattice(bufs, gs, &near_sheet(tiles, grid, &gs.params))?;
        }
        let (vals, classes) = self.run_pass_with(bufs, gs, params, PassKind::Objects, false, tiles)?;
        // Per pixel of the image: its class and value (pixels outside the tiles see no object;
        // where no object is in front, the value is the target passes').
        let mut class = vec![0u32; w * h];
        let mut value = img.to_vec();
        // Under an area light: the coarse pass's soft-shadow ratio per target pixel (1 elsewhere),
        // which scales the sheet's share of each fine pixel.
        let mut ratio = if soft { vec![1.0f32; w * h] } else { Vec::new() };
        for (j, packed) in tiles.iter().enumerate() {
            for (k, x, y) in tile_pixels(*packed, w, h) {
                let i = y * w + x;
                class[i] = classes[j * 64 + k];
                if soft && on_target(class[i]) {
                    ratio[i] = vals[j * 64 + k];
                }
                // Where no object is in front, the target's value (from its own passes).
                value[i] = match class[i] {
                    0 => img[i],
                    SHADOW_CLASS => img[i] * vals[j * 64 + k],
                    _ => vals[j * 64 + k],
                };
            }
        }
        // A soft shadow is continuous: where it begins is no edge (its pixels hold the target
        // passes' exact value times the pixel's ratio already), so the edges are looked for with
        // shadowed target pixels counted as target pixels.
        let edge_class: std::borrow::Cow<'_, [u32]> =
            if soft { class.iter().map(|c| if *c == SHADOW_CLASS { 0 } else { *c }).collect::<Vec<_>>().into() } else { (&class[..]).into() };
        let mut fine = Vec::new();
        for packed in tiles {
            for (_, x, y) in tile_pixels(*packed, w, h) {
                let i = y * w + x;
                if let Some(how) = edge(&edge_class, &value, w, h, x, y) {
                    let flags = match how {
                        Fine::Lines => u32::from(across_columns(&edge_class, &value, w, h, x, y)) << 15,
                        Fine::Grid => 1 << 31,
                    };
                    fine.push((x | (y << 16)) as u32 | flags);
                } else if class[i] != 0 {
                    img[i] = value[i];
                }
            }
        }
        // Lanes of one kind together: llvmpipe runs a batch's loops for all of its lanes.
        fine.sort_by_key(|p| p >> 31);
        log::debug!("objects: {} tiles, {} fine pixels ({} on a grid)", tiles.len(), fine.len(), fine.iter().filter(|p| **p >> 31 == 1).count());
        if !fine.is_empty() {
            let (vals, sheet) = self.run_pass(bufs, gs, PassKind::Objects, true, &fine)?;
            for (j, (packed, v)) in fine.iter().zip(vals).enumerate() {
                let (x, y) = ((packed & 0x7fff) as usize, ((packed >> 16) & 0x7fff) as usize);
                img[y * w + x] = match sheet.get(j) {
                    Some(s) if soft => v + (pixel_ratio(&class, &ratio, w, h, x, y) - 1.0) * f32::from_bits(*s),
                    _ => v,
                };
            }
        }
        Ok(())
    }
}

impl Renderer {
    /// Under an area light: the soft-shadow lattice of `tiles` computed in two passes
    /// (`super::soft_lattice`) and written behind the instances in the objects' buffer; its
    /// first row there, for `Params::soft_v`'s w (0, no lattice, without tiles).
    fn soft_lattice(&self, bufs: &mut Buffers, gs: &GpuScene, tiles: &[u32]) -> Result<f32, RenderError> {
        if tiles.is_empty() {
            return Ok(0.0);
        }
        let (tiles_x, tiles_y) = (gs.params.tiles[0], gs.params.tiles[1]);
        let mut lattice = Lattice::new(tiles_x, tiles_y);
        let mut params = gs.params;
        params.soft_v[3] = -1.0;
        let work = lattice.tile_work(tiles);
        lattice.record(&work, &self.run_pass_with(bufs, gs, params, PassKind::Objects, true, &work)?.0);
        let failed = lattice.decide_tiles(tiles);
        let quad_work = lattice.quad_work(&failed);
        if !quad_work.is_empty() {
            lattice.record(&quad_work, &self.run_pass_with(bufs, gs, params, PassKind::Objects, true, &quad_work)?.0);
        }
        lattice.decide_quads(&failed);
        let start = gs.params.obj[1] as usize + 5 * gs.params.obj[0] as usize;
        let buffer = bufs.objs.get(&self.context().device, "objs", ((start + Lattice::rows(tiles_x, tiles_y)) * 16) as u64, STORAGE_DST);
        self.context().queue.write_buffer(buffer, (start * 16) as u64, bytemuck::cast_slice(&lattice.values()));
        let (from_tiles, from_quads) = lattice.counts();
        log::debug!(
            "objects: soft-shadow lattice of {} + {} points; of {} quads {from_tiles} interpolated over their tile, {from_quads} over themselves",
            work.len(),
            quad_work.len(),
            4 * tiles.len()
        );
        Ok(start as f32)
    }
}

/// Textured classes (`TEXTURED_CLASS` in `shaders/objects.wgsl`): their values are box-filtered
/// over the pixel already, so only a change of class marks an edge.
const TEXTURED_CLASS: u32 = 0x4000_0000;
/// The class of target pixels in an object's shadow (`SHADOW_CLASS` in `shaders/objects.wgsl`):
/// like class 0 they hold the target passes' (box-filtered) values, scaled.
const SHADOW_CLASS: u32 = 0x8000_0000;
/// An untextured pixel whose value departs from the mean of its two neighbours (along x or y, same
/// object) by more than this (grey levels) holds an edge between materials or facets: a smooth
/// shade (a lit sphere) has small second differences, a step has them as large as half the step.
const VALUE_STEP: f32 = 0.5;

/// The pixels of tile `packed` inside the image: (index in the tile, x, y).
fn tile_pixels(packed: u32, w: usize, h: usize) -> impl Iterator<Item = (usize, usize, usize)> {
    let (tx, ty) = ((packed & 0xffff) as usize * TILE_PX as usize, (packed >> 16) as usize * TILE_PX as usize);
    (0..64usize).map(move |k| (k, tx + k % 8, ty + k / 8)).filter(move |(_, x, y)| *x < w && *y < h)
}

/// Whether a coarse class is the target's (or the background's): no object in front.
fn on_target(class: u32) -> bool {
    matches!(class, 0 | SHADOW_CLASS)
}

/// The soft-shadow ratio for the sheet's share of pixel (x, y): its own where the coarse pass saw
/// the target there, else the mean of its 8-neighbours' that saw it (an object's outline: the ratio
/// varies smoothly across it), else 1.
fn pixel_ratio(class: &[u32], ratio: &[f32], w: usize, h: usize, x: usize, y: usize) -> f32 {
    let target = |i: usize| on_target(class[i]);
    if target(y * w + x) {
        return ratio[y * w + x];
    }
    let (mut sum, mut n) = (0.0f32, 0.0f32);
    for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
        let (u, v) = (x as i64 + dx, y as i64 + dy);
        if u >= 0 && v >= 0 && (u as usize) < w && (v as usize) < h && target(v as usize * w + u as usize) {
            sum += ratio[v as usize * w + u as usize];
            n += 1.0;
        }
    }
    if n > 0.0 {
        sum / n
    } else {
        1.0
    }
}

/// How the fine pass integrates a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fine {
    /// Scan lines across one edge between two untextured regions (exact for a straight edge).
    Lines,
    /// A grid of `samples^2` sub-samples: textures, facet or material steps inside an object,
    /// where three regions meet.
    Grid,
}

/// Whether pixel (x, y) needs the fine pass, and how: a 4-neighbour of another class (an object's silhouette, or where objects and the target meet), or, untextured, a
/// second difference of its value along x or y above [`VALUE_STEP`].
fn edge(class: &[u32], value: &[f32], w: usize, h: usize, x: usize, y: usize) -> Option<Fine> {
    let i = y * w + x;
    let c = class[i];
    let at = |u: i64, v: i64| (u >= 0 && v >= 0 && u < w as i64 && v < h as i64).then(|| v as usize * w + u as usize);
    let (xi, yi) = (x as i64, y as i64);
    let (mut other, mut textured, mut third) = (None, c & TEXTURED_CLASS != 0, false);
    // Per side (this pixel's class, the other) the range of values: both flat for scan lines.
    let (mut mine, mut theirs) = ([f32::INFINITY, f32::NEG_INFINITY], [f32::INFINITY, f32::NEG_INFINITY]);
    // The 4-neighbours: a straight edge that leaves them all on this pixel's side misses the
    // pixel (it can only touch its corner), so they decide.
    for j in [(0, 0), (-1, 0), (1, 0), (0, -1), (0, 1)].into_iter().filter_map(|(dx, dy)| at(xi + dx, yi + dy)) {
        textured |= class[j] & TEXTURED_CLASS != 0;
        let side = if class[j] == c { &mut mine } else { &mut theirs };
        *side = [side[0].min(value[j]), side[1].max(value[j])];
        if class[j] != c {
            third |= other.is_some_and(|o| o != class[j]);
            other = Some(class[j]);
        }
    }
    if other.is_some() {
        // Class 0 holds the target passes' values (box-filtered): flat only away from its edges.
        let flat = mine[1] - mine[0] <= 1.0 && theirs[1] - theirs[0] <= 1.0;
        return Some(if textured || third || !flat { Fine::Grid } else { Fine::Lines });
    }
    if c == 0 || c == SHADOW_CLASS || textured {
        return None;
    }
    let bends = |a: Option<usize>, b: Option<usize>| match (a, b) {
        (Some(a), Some(b)) => (value[a] + value[b] - 2.0 * value[i]).abs() > 2.0 * VALUE_STEP,
        _ => false,
    };
    (bends(at(xi - 1, yi), at(xi + 1, yi)) || bends(at(xi, yi - 1), at(xi, yi + 1))).then_some(Fine::Grid)
}

/// Whether the fine pass should scan pixel (x, y) along columns: its neighbours above and below
/// differ from it more often than those left and right (a more horizontal edge).
fn across_columns(class: &[u32], value: &[f32], w: usize, h: usize, x: usize, y: usize) -> bool {
    let i = y * w + x;
    let differs = |u: i64, v: i64| {
        (u >= 0 && v >= 0 && u < w as i64 && v < h as i64) && {
            let j = v as usize * w + u as usize;
            class[j] != class[i] || (value[j] - value[i]).abs() > 1.0
        }
    };
    let (xi, yi) = (x as i64, y as i64);
    let along_x = u8::from(differs(xi - 1, yi)) + u8::from(differs(xi + 1, yi));
    let along_y = u8::from(differs(xi, yi - 1)) + u8::from(differs(xi, yi + 1));
    along_y > along_x
}
