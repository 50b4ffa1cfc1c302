//! GPU buffers the renderer keeps between frames.

pub(super) const STORAGE_DST: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_DST);
pub(super) const STORAGE_SRC: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE.union(wgpu::BufferUsages::COPY_SRC);
pub(super) const READBACK: wgpu::BufferUsages = wgpu::BufferUsages::MAP_READ.union(wgpu::BufferUsages::COPY_DST);

/// A storage buffer reused between frames, grown when too small.
#[derive(Debug, Default)]
pub(super) struct Slot {
    buffer: Option<wgpu::Buffer>,
}

impl Slot {
    pub(super) fn get(&mut self, device: &wgpu::Device, label: &str, size: u64, usage: wgpu::BufferUsages) -> &wgpu::Buffer {
        let size = size.max(16).next_multiple_of(16);
        if self.buffer.as_ref().is_none_or(|b| b.size() < size) {
            self.buffer = Some(device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false }));
        }
        self.buffer.get_or_insert_with(|| unreachable_buffer(device))
    }
}

fn unreachable_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor { label: None, size: 16, usage: wgpu::BufferUsages::STORAGE, mapped_at_creation: false })
}

/// Buffers kept between frames.
#[derive(Debug, Default)]
pub(super) struct Buffers {
    pub(super) dots: Slot,
    pub(super) tile_start: Slot,
    pub(super) tile_items: Slot,
    pub(super) work: Slot,
    pub(super) views: Slot,
    pub(super) vals: Slot,
    pub(super) hard: Slot,
    pub(super) staging_vals: Slot,
    pub(super) staging_hard: Slot,
    /// Objects: meshes then instances (`super::objects`).
    pub(super) objs: Slot,
    /// The meshes whose rows `objs` holds.
    pub(super) objs_meshes: Option<std::sync::Arc<super::objects::MeshRows>>,
    /// The background's texels and prefix sums (`super::background`).
    pub(super) bg: Slot,
    /// The image whose rows `bg` holds.
    pub(super) bg_texture: Option<std::sync::Arc<synthcam_core::mesh::Texture>>,
    /// Its min / max pyramid (flat background tiles: `super::bg_tiles`).
    pub(super) bg_pyramid: Option<std::sync::Arc<super::bg_tiles::MinMaxPyramid>>,
}

impl Slot {
    /// The buffer's size in bytes (0 before the first `get`).
    pub(super) fn size(&self) -> u64 {
        self.buffer.as_ref().map_or(0, wgpu::Buffer::size)
    }
}
