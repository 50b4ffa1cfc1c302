//! `synthcam render SCENE -o OUT.png`.

use std::path::PathBuf;

use anyhow::Context;
use synthcam::dataset::write_image_and_truth;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;

/// Arguments of `render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Scene file (TOML, or JSON).
    pub scene: PathBuf,
    /// Output PNG; the truth JSON goes beside it with the extension `.json`.
    #[arg(short, long)]
    pub out: PathBuf,
    /// GPU backend: auto (Vulkan, then GL), vulkan or gl.
    #[arg(long, default_value = "auto")]
    pub backend: String,
}

/// Run `render`.
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.scene).with_context(|| format!("reading {}", args.scene.display()))?;
    let scene = parse_scene(&text).with_context(|| format!("in scene {}", args.scene.display()))?;
    let renderer = super::open_renderer(&args.backend)?;
    let img = renderer.render(&scene).context("rendering")?;
    let truth = truth_labels(&scene);
    write_image_and_truth(&args.out, &img, &truth)?;
    let visible = truth.features.iter().filter(|f| f.visible).count();
    println!("wrote {} and {} ({} of {} features visible)", args.out.display(), args.out.with_extension("json").display(), visible, truth.features.len());
    Ok(())
}
