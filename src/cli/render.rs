//! `synthcam render SCENE -o OUT.png` (a rig: `OUT.<camera>.png` per camera).

use std::path::PathBuf;

use anyhow::Context;
use synthcam::dataset::extras::{encode_mask_png, encode_npy_f32};
use synthcam::dataset::MeshLibrary;
use synthcam::dataset::{encode_image, truth_json, write_atomic, write_png_and_json};
use synthcam::scene::file::parse_spec;
use synthcam::scene::truth::truth_labels;

/// Arguments of `render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (TOML, or JSON).
    pub scene: PathBuf,
    /// Output image (PNG, or JPEG when the scene's `[output] encoding` says so); the truth JSON
    /// goes beside it with the extension `.json`.
    #[arg(short, long)]
    pub out: PathBuf,
    /// GPU backend: auto (Vulkan, then GL), vulkan or gl.
    #[arg(long, default_value = "auto")]
    pub backend: String,
    /// Also write the depth image (NPY, float32 metres, camera z; NaN where nothing is seen).
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// Also write the instance mask (16-bit PNG: 0 nothing, 1 the target, 2 + i object i).
    #[arg(long)]
    pub mask: Option<PathBuf>,
}

/// Run `render`: one image, or one per camera of a rig (`[[cameras]]`: `OUT.<name>.png` and its
/// truth beside it).
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.scene).with_context(|| format!("reading {}", args.scene.display()))?;
    let meshes = MeshLibrary::beside(&args.scene);
    let spec = parse_spec(&text).with_context(|| format!("in scene {}", args.scene.display()))?;
    if spec.cameras.is_empty() {
        let scene = spec.to_scene_with(&meshes).with_context(|| format!("in scene {}", args.scene.display()))?;
        return render_one(args, &super::open_renderer(&args.backend)?, &scene, &args.out);
    }
    anyhow::ensure!(args.depth.is_none() && args.mask.is_none(), "--depth and --mask take a single-camera scene, not a rig");
    let scenes = spec.to_rig_scenes_with(&meshes).with_context(|| format!("in scene {}", args.scene.display()))?;
    let renderer = super::open_renderer(&args.backend)?;
    let stem = args.out.file_stem().map_or_else(|| "render".to_string(), |s| s.to_string_lossy().into_owned());
    let ext = args.out.extension().map_or_else(|| "png".to_string(), |e| e.to_string_lossy().into_owned());
    for (name, scene) in &scenes {
        render_one(args, &renderer, scene, &args.out.with_file_name(format!("{stem}.{name}.{ext}")))?;
    }
    Ok(())
}

/// Render `scene` to `out` (and its truth, depth, mask as asked).
fn render_one(args: &RenderArgs, renderer: &synthcam::render::Renderer, scene: &synthcam::scene::Scene, out: &std::path::Path) -> anyhow::Result<()> {
    let img = renderer.render(scene).context("rendering")?;
    let truth = truth_labels(scene);
    // PNG or JPEG as the scene's [output] asks (the bytes go to --out whatever its extension).
    let extras = (args.depth.is_some() || args.mask.is_some()).then(|| synthcam::scene::depth::depth_mask(scene));
    if let (Some(path), Some(m)) = (&args.depth, &extras) {
        write_atomic(path, &encode_npy_f32(m.width, m.height, &m.depth_m))?;
    }
    if let (Some(path), Some(m)) = (&args.mask, &extras) {
        write_atomic(path, &encode_mask_png(m)?)?;
    }
    write_png_and_json(out, &encode_image(&img, &scene.render.effects.output)?, &truth_json(&truth)?)?;
    let visible = truth.features.iter().filter(|f| f.visible).count();
    println!("wrote {} and {} ({} of {} features visible)", out.display(), out.with_extension("json").display(), visible, truth.features.len());
    Ok(())
}
