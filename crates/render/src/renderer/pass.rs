//! One compute pass: its inputs uploaded, its work list dispatched, its outputs read back.

use super::Renderer;
use crate::buffers::{Buffers, READBACK, STORAGE_DST, STORAGE_SRC};
use crate::gpu_scene::{GpuScene, PassKind};
use crate::uniforms::Params;
use crate::RenderError;

/// Most workgroups along one dispatch dimension (WebGPU's minimum limit).
const MAX_GROUPS_X: u64 = 65535;

/// Workgroup counts covering `groups` along x then y.
fn grid(groups: u64) -> (u32, u32) {
    let groups = groups.max(1);
    (groups.min(MAX_GROUPS_X) as u32, groups.div_ceil(MAX_GROUPS_X) as u32)
}

impl Renderer {
    /// One compute pass over `items` work items, then read back `vals` (f32) and, for coarse
    /// passes, the hard flags (u32).
    pub(crate) fn run_pass(&self, bufs: &mut Buffers, gs: &GpuScene, kind: PassKind, fine: bool, work: &[u32]) -> Result<(Vec<f32>, Vec<u32>), RenderError> {
        self.run_pass_with(bufs, gs, gs.params, kind, fine, work)
    }

    /// [`Self::run_pass`] under the uniforms `params` instead of `gs.params`.
    pub(crate) fn run_pass_with(
        &self,
        bufs: &mut Buffers,
        gs: &GpuScene,
        mut params: Params,
        kind: PassKind,
        fine: bool,
        work: &[u32],
    ) -> Result<(Vec<f32>, Vec<u32>), RenderError> {
        let t0 = std::time::Instant::now();
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        params.tiles[3] = work.len() as u32;
        let (groups, outputs) = if fine {
            let g = (work.len() as u64).div_ceil(64);
            (g, g * 64)
        } else {
            (work.len() as u64, work.len() as u64 * 64)
        };
        let out_bytes = outputs * 4;
        // Storage buffers beyond the device's binding limit would fail validation (a panic in
        // wgpu's default error handler): refuse them (rolling-shutter views are rows x samples).
        let max_bytes = device.limits().max_storage_buffer_binding_size;
        if out_bytes.max((gs.views.len() * 16) as u64).max((gs.tile_items.len() * 4) as u64) > max_bytes {
            return Err(RenderError::TooLarge { width: gs.params.size[0], height: gs.params.size[1], max_bytes });
        }
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&params));
        let dots = bufs.dots.get(device, "dots", (gs.dots.len() * 16) as u64, STORAGE_DST);
        queue.write_buffer(dots, 0, bytemuck::cast_slice(&gs.dots));
        let tile_start = bufs.tile_start.get(device, "tile_start", (gs.tile_start.len() * 4) as u64, STORAGE_DST);
        queue.write_buffer(tile_start, 0, bytemuck::cast_slice(&gs.tile_start));
        let tile_items = bufs.tile_items.get(device, "tile_items", (gs.tile_items.len() * 4) as u64, STORAGE_DST);
        queue.write_buffer(tile_items, 0, bytemuck::cast_slice(&gs.tile_items));
        let work_buf = bufs.work.get(device, "work", (work.len() * 4) as u64, STORAGE_DST);
        queue.write_buffer(work_buf, 0, bytemuck::cast_slice(work));
        let views = bufs.views.get(device, "views", (gs.views.len() * 16) as u64, STORAGE_DST);
        queue.write_buffer(views, 0, bytemuck::cast_slice(&gs.views));
        let objs = bufs.objs.get(device, "objs", 16, STORAGE_DST);
        let bg = bufs.bg.get(device, "background", 16, STORAGE_DST);
        let vals = bufs.vals.get(device, "vals", out_bytes, STORAGE_SRC);
        let hard = bufs.hard.get(device, "hard", out_bytes, STORAGE_SRC);
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("synthcam"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: vals.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: dots.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: tile_start.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: tile_items.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: work_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: hard.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 7, resource: views.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 8, resource: objs.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 9, resource: bg.as_entire_binding() },
            ],
        });
        let staging_vals = bufs.staging_vals.get(device, "staging_vals", out_bytes, READBACK);
        let staging_hard = bufs.staging_hard.get(device, "staging_hard", out_bytes, READBACK);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("render") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(if fine { "fine" } else { "coarse" }), timestamp_writes: None });
            pass.set_pipeline(self.pipeline(kind, fine, gs.lens_variant));
            pass.set_bind_group(0, &bind, &[]);
            let (gx, gy) = grid(groups);
            pass.dispatch_workgroups(gx, gy, 1);
        }
        enc.copy_buffer_to_buffer(vals, 0, staging_vals, 0, out_bytes);
        // The fine objects pass under an area light returns each pixel's sheet share there.
        let with_hard = !fine || (kind == PassKind::Objects && gs.params.soft_shadows());
        if with_hard {
            enc.copy_buffer_to_buffer(hard, 0, staging_hard, 0, out_bytes);
        }
        queue.submit([enc.finish()]);
        let n = if fine { work.len() } else { outputs as usize };
        let (v, h) = read_back(device, staging_vals, with_hard.then_some(staging_hard), out_bytes, n)?;
        log::debug!("pass kind {kind:?} fine {fine}: {} items in {:.2} ms", work.len(), t0.elapsed().as_secs_f64() * 1e3);
        Ok((v, h))
    }
}

/// Map the staging buffers (values, and the hard flags when given), wait for the device and copy
/// out the first `n` words of each.
fn read_back(
    device: &wgpu::Device,
    staging_vals: &wgpu::Buffer,
    staging_hard: Option<&wgpu::Buffer>,
    out_bytes: u64,
    n: usize,
) -> Result<(Vec<f32>, Vec<u32>), RenderError> {
    let mut slices = vec![staging_vals.slice(..out_bytes)];
    if let Some(h) = staging_hard {
        slices.push(h.slice(..out_bytes));
    }
    let (tx, rx) = std::sync::mpsc::channel();
    for s in &slices {
        let tx = tx.clone();
        s.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
    }
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Device(e.to_string()))?;
    for _ in &slices {
        rx.recv().map_err(|e| RenderError::Device(e.to_string()))?.map_err(|e| RenderError::Device(e.to_string()))?;
    }
    let read = |s: &wgpu::BufferSlice<'_>| -> Result<Vec<u8>, RenderError> {
        let view = s.get_mapped_range().map_err(|e| RenderError::Device(e.to_string()))?;
        Ok(view[..n * 4].to_vec())
    };
    let v: Vec<f32> = bytemuck::pod_collect_to_vec(&read(&slices[0])?);
    let h: Vec<u32> = match slices.get(1) {
        Some(s) => bytemuck::pod_collect_to_vec(&read(s)?),
        None => Vec::new(),
    };
    drop(slices);
    staging_vals.unmap();
    if let Some(h) = staging_hard {
        h.unmap();
    }
    Ok((v, h))
}
