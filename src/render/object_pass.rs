//! The objects' passes (`shaders/objects.wgsl`), after the target's: a coarse pass over the
//! tiles an object may cover (pixel-corner rays; each pixel keeps the target's value, takes the
//! object's, or is flagged) and a fine pass of `samples^2` exact rays per flagged pixel.

use std::sync::Arc;

use super::buffers::{Buffers, STORAGE_DST};
use super::gpu_scene::{GpuScene, OBJECTS_KIND, TILE_PX};
use super::objects::{instance_rows, object_params, MeshRows};
use super::{RenderError, Renderer};
use crate::scene::Scene;

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
        let bytes = ((meshes.rows.len() + instances.len()) * 16) as u64;
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

    /// Run the objects' passes over `tiles` and write their pixels into `img`.
    pub(super) fn render_objects(&self, bufs: &mut Buffers, gs: &GpuScene, tiles: &[u32], img: &mut [f32]) -> Result<(), RenderError> {
        if tiles.is_empty() {
            return Ok(());
        }
        let (w, h) = (gs.params.size[0], gs.params.size[1]);
        let tc = std::time::Instant::now();
        let (vals, flags) = self.run_pass(bufs, gs, OBJECTS_KIND, false, tiles)?;
        if std::env::var("SC_TIMING").is_ok() {
            eprintln!("coarse {:.1} ms", tc.elapsed().as_secs_f64() * 1e3);
        }
        let mut fine = Vec::new();
        for (j, packed) in tiles.iter().enumerate() {
            let (tx, ty) = (packed & 0xffff, packed >> 16);
            for k in 0..(TILE_PX * TILE_PX) as usize {
                let (x, y) = (tx * TILE_PX + k as u32 % TILE_PX, ty * TILE_PX + k as u32 / TILE_PX);
                if x >= w || y >= h {
                    continue;
                }
                match flags[j * 64 + k] {
                    1 => img[y as usize * w as usize + x as usize] = vals[j * 64 + k],
                    2 => fine.push(x | (y << 16)),
                    _ => {}
                }
            }
        }
        log::debug!("objects: {} tiles, {} fine pixels", tiles.len(), fine.len());
        let t0 = std::time::Instant::now();
        if !fine.is_empty() {
            let (vals, _) = self.run_pass(bufs, gs, OBJECTS_KIND, true, &fine)?;
            for (packed, v) in fine.iter().zip(vals) {
                img[(packed >> 16) as usize * w as usize + (packed & 0xffff) as usize] = v;
            }
        }
        if std::env::var("SC_TIMING").is_ok() {
            eprintln!("objects: {} tiles, {} fine px, fine {:.1} ms", tiles.len(), fine.len(), t0.elapsed().as_secs_f64() * 1e3);
        }
        Ok(())
    }
}
