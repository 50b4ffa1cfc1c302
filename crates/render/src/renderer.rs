//! The compute pipelines and their orchestration.
//!
//! llvmpipe runs every branch of a shader under a lane mask, so work is skipped by not dispatching
//! it: the CPU fills the tiles that hold no edge (see `gpu_scene`); the *coarse* pass runs
//! one 8 x 8 workgroup per remaining tile and flags the pixels that need more than one ray or one
//! closed-form coverage; the *fine* pass runs one invocation per flagged pixel. Values come back
//! in work-list order and the CPU scatters them into the image.

use std::sync::{Arc, Mutex, OnceLock};

use super::buffers::Buffers;
use super::context::{BackendChoice, GpuContext};
use super::gpu_scene::{gpu_scene, pipeline_variant, scene_pass_kind, GpuScene, PassKind, LENS_VARIANTS, PIPELINE_VARIANTS};
use super::shader::SHADER;
use super::tiles::{TileCornerRays, TILE_PX};
use super::{GreyImage, RenderError};
use synthcam_scene::shadow::{ObjectLight, ShadowLight};
use synthcam_scene::Scene;

mod pass;

/// A GPU renderer bound to one device. Safe to share between threads (frames are serialised).
///
/// Pipelines are compiled on first use: a process that renders one chessboard compiles the
/// chessboard's two entry points, not all seven (on lavapipe each costs LLVM time at start-up).
#[derive(Debug)]
pub struct Renderer {
    ctx: GpuContext,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    /// Per target kind, coarse / fine, lens variant (`gpu_scene::LENS_VARIANTS`).
    pipelines: [[[OnceLock<wgpu::ComputePipeline>; PIPELINE_VARIANTS]; 2]; PassKind::COUNT],
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    buffers: Mutex<Buffers>,
    corner_rays: Mutex<Option<Arc<TileCornerRays>>>,
    /// The meshes' GPU rows of the last scene with objects (`super::objects`).
    pub(super) mesh_rows: Mutex<Option<Arc<super::objects::MeshRows>>>,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

impl Renderer {
    /// A renderer on the default headless adapter (Vulkan, then GL: [`GpuContext::new_headless`]).
    ///
    /// # Errors
    /// No adapter or device.
    pub fn headless() -> Result<Self, RenderError> {
        Self::with_backend(BackendChoice::Auto)
    }

    /// A renderer on a device of the chosen backend ([`GpuContext::with_backend`]). The shader
    /// is parsed on another thread while the device opens (on lavapipe, loading LLVM takes some
    /// 30 ms and parsing the WGSL 10 ms).
    ///
    /// # Errors
    /// No adapter or device.
    pub fn with_backend(choice: BackendChoice) -> Result<Self, RenderError> {
        let parsing = std::thread::spawn(|| wgpu::naga::front::wgsl::parse_str(SHADER).ok());
        let ctx = GpuContext::with_backend(choice)?;
        Ok(Self::with_parsed(ctx, parsing.join().ok().flatten()))
    }

    /// Render `scene` and label it: the image and its truth ([`synthcam_scene::truth_labels`]).
    ///
    /// # Errors
    /// As [`Renderer::render`].
    pub fn render_with_truth(&self, scene: &Scene) -> Result<(GreyImage, synthcam_scene::TruthLabels), RenderError> {
        Ok((self.render(scene)?, synthcam_scene::truth_labels(scene)))
    }

    /// Compile the shader on `ctx`; each pipeline is built on first use.
    pub fn new(ctx: GpuContext) -> Self {
        Self::with_parsed(ctx, None)
    }

    /// [`Renderer::new`] with the shader already parsed (`None`: wgpu parses it).
    fn with_parsed(ctx: GpuContext, parsed: Option<wgpu::naga::Module>) -> Self {
        let device = &ctx.device;
        let source = match parsed {
            Some(m) => wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(m)),
            None => wgpu::ShaderSource::Wgsl(SHADER.into()),
        };
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("synthcam shaders"), source });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("synthcam"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                    count: None,
                },
                storage_entry(1, false),
                storage_entry(2, true),
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, true),
                storage_entry(6, false),
                storage_entry(7, true),
                storage_entry(8, true),
                storage_entry(9, true),
            ],
        });
        let pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("synthcam"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<super::uniforms::Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            ctx,
            module,
            pipeline_layout,
            pipelines: Default::default(),
            layout,
            uniform,
            buffers: Mutex::new(Buffers::default()),
            corner_rays: Mutex::new(None),
            mesh_rows: Mutex::new(None),
        }
    }

    /// The pipeline of pass `kind` (coarse or fine) for pipeline `variant`
    /// ([`super::gpu_scene::pipeline_variant`]), compiled on first use.
    fn pipeline(&self, kind: PassKind, fine: bool, variant: usize) -> &wgpu::ComputePipeline {
        self.pipelines[kind as usize][usize::from(fine)][variant].get_or_init(|| {
            let entry = kind.entry_points()[usize::from(fine)];
            let t0 = std::time::Instant::now();
            let (model, tilt) = LENS_VARIANTS[variant % LENS_VARIANTS.len()];
            let warped = f64::from(u8::from(variant >= LENS_VARIANTS.len()));
            let constants = [("LENS_MODEL", model), ("LENS_TILT", f64::from(u8::from(tilt))), ("PASS_KIND", f64::from(kind as u32)), ("WARPED", warped)];
            let p = self.ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&self.pipeline_layout),
                module: &self.module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
                cache: None,
            });
            log::debug!("pipeline {entry} compiled in {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
            p
        })
    }

    /// The device this renderer runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    fn corner_rays(&self, scene: &Scene) -> Result<Arc<TileCornerRays>, RenderError> {
        let mut cache = self.corner_rays.lock().map_err(|_| RenderError::Device("renderer mutex poisoned".into()))?;
        Ok(match cache.as_ref() {
            Some(g) if g.camera == scene.camera => g.clone(),
            _ => {
                let g = Arc::new(TileCornerRays::new(&scene.camera));
                *cache = Some(g.clone());
                g
            }
        })
    }

    /// Render the geometry of `scene` (no blur, no noise): grey levels as f32, row-major.
    ///
    /// # Errors
    /// Invalid scene, degenerate view, or a device failure.
    pub fn render_linear(&self, scene: &Scene) -> Result<Vec<f32>, RenderError> {
        scene.validate()?;
        // Lights on a flat board are one factor on its grey levels (synthcam_scene::lighting).
        let lights = (synthcam_scene::shadow::shadow_light(scene), synthcam_scene::shadow::ObjectLight::of(scene));
        let shaded = synthcam_scene::lighting::shade(scene)?;
        let scene: &Scene = &shaded;
        std::thread::scope(|scope| {
            self.compile_ahead(scope, scene);
            self.render_valid(scene, &lights)
        })
    }

    /// Start building, on threads of `scope`, the pipelines `scene` needs that are not built
    /// yet: on lavapipe each takes tens of milliseconds of shader compilation (27 and 41 ms for
    /// the chessboard's coarse and fine passes), which then overlap each other and the CPU's
    /// layout of the scene instead of following one another.
    fn compile_ahead<'s>(&'s self, scope: &'s std::thread::Scope<'s, '_>, scene: &Scene) {
        let variant = pipeline_variant(scene);
        let kind = scene_pass_kind(scene);
        let limb = (kind == PassKind::SPath).then_some((PassKind::SPathLimb, false));
        let objects = if scene.objects.is_empty() { Vec::new() } else { vec![(PassKind::Objects, false), (PassKind::Objects, true)] };
        let background = scene.background.is_some().then_some((PassKind::Background, true));
        for (kind, fine) in [(kind, false), (kind, true)].into_iter().chain(limb).chain(objects).chain(background) {
            if self.pipelines[kind as usize][usize::from(fine)][variant].get().is_none() {
                scope.spawn(move || {
                    self.pipeline(kind, fine, variant);
                });
            }
        }
    }

    /// [`Renderer::render_linear`] of a validated scene (its lighting folded into its greys; the
    /// scene's lights as given: the one that casts the objects' shadows on the target and the one
    /// on lit objects, `synthcam_scene::shadow`).
    fn render_valid(&self, scene: &Scene, (sun, on_objects): &(Option<ShadowLight>, ObjectLight)) -> Result<Vec<f32>, RenderError> {
        let grid_rays = self.corner_rays(scene)?;
        let mut gs: GpuScene = gpu_scene(scene, &grid_rays)?;
        let mut bufs = self.buffers.lock().map_err(|_| RenderError::Device("renderer mutex poisoned".into()))?;
        if !scene.objects.is_empty() {
            super::objects::shadow_params(&mut gs.params, sun.as_ref(), on_objects);
            self.upload_objects(&mut bufs, &mut gs, scene)?;
        }
        self.upload_background(&mut bufs, scene)?;
        let mut img = self.target_image(&mut bufs, &gs, scene)?;
        self.compose_background(&mut bufs, &gs, scene, &grid_rays, &mut img)?;
        if !scene.objects.is_empty() {
            self.render_objects(&mut bufs, &gs, &super::objects::object_tiles(scene, &grid_rays, sun.as_ref()), &grid_rays, &mut img)?;
        }
        Ok(img)
    }

    /// The target's passes of `gs`: its flat tiles filled, the others' coarse and fine passes.
    pub(super) fn target_image(&self, bufs: &mut Buffers, gs: &GpuScene, scene: &Scene) -> Result<Vec<f32>, RenderError> {
        let (w, h) = (scene.camera.size.width, scene.camera.size.height);
        let (tiles_x, _) = (gs.params.tiles[0], gs.params.tiles[1]);
        let mut img = vec![0.0f32; w as usize * h as usize];
        let kind = scene_pass_kind(scene);
        // Work lists per pass kind: S-path tiles without dots get the cheaper limb-only pass.
        let mut work: [Vec<u32>; PassKind::COUNT] = Default::default();
        for (t, v) in gs.tile_flat.iter().enumerate() {
            let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
            if *v >= 0.0 {
                for y in ty * TILE_PX..((ty + 1) * TILE_PX).min(h) {
                    let row = y as usize * w as usize;
                    img[row + (tx * TILE_PX) as usize..row + ((tx + 1) * TILE_PX).min(w) as usize].fill(*v);
                }
            } else {
                let has_dots = gs.tile_start[t + 1] > gs.tile_start[t];
                let k = if kind == PassKind::SPath && !has_dots { PassKind::SPathLimb } else { kind };
                work[k as usize].push(tx | (ty << 16));
            }
        }
        let mut fine_work = Vec::new();
        for (k, list) in work.iter().enumerate().filter(|(_, l)| !l.is_empty()) {
            let (vals, hard) = self.run_pass(bufs, gs, PassKind::ALL[k], false, list)?;
            for (j, packed) in list.iter().enumerate() {
                let (tx, ty) = (packed & 0xffff, packed >> 16);
                for ly in 0..TILE_PX {
                    for lx in 0..TILE_PX {
                        let (x, y) = (tx * TILE_PX + lx, ty * TILE_PX + ly);
                        if x >= w || y >= h {
                            continue;
                        }
                        let slot = j * 64 + (ly * TILE_PX + lx) as usize;
                        img[y as usize * w as usize + x as usize] = vals[slot];
                        if hard[slot] != 0 {
                            fine_work.push(x | (y << 16));
                        }
                    }
                }
            }
        }
        log::debug!("{:?} coarse tiles per pass kind, {} fine pixels", work.each_ref().map(Vec::len), fine_work.len());
        if !fine_work.is_empty() {
            let (vals, _) = self.run_pass(bufs, gs, kind, true, &fine_work)?;
            for (packed, v) in fine_work.iter().zip(vals) {
                img[(packed >> 16) as usize * w as usize + (packed & 0xffff) as usize] = v;
            }
        }
        Ok(img)
    }
}
