//! `synthcam demo`: renders the embedded default scenes and writes them with their truth.

use std::path::Path;

use anyhow::Context;
use synthcam::dataset::write_image_and_truth;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;

/// Run the demo into `out`.
pub fn run(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let renderer = super::open_renderer("auto")?;
    for (name, text) in super::DEFAULT_SCENES {
        let scene = parse_scene(text).with_context(|| format!("embedded scene {name}"))?;
        let t0 = std::time::Instant::now();
        let img = renderer.render(&scene).with_context(|| format!("rendering {name}"))?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let truth = truth_labels(&scene);
        let path = out.join(format!("{name}.png"));
        write_image_and_truth(&path, &img, &truth)?;
        let visible = truth.features.iter().filter(|f| f.visible).count();
        println!(
            "{name}: {}x{} {} in {ms:.0} ms, {visible}/{} features visible -> {}",
            scene.camera.size.width,
            scene.camera.size.height,
            scene.target.kind_name(),
            truth.features.len(),
            path.display()
        );
    }
    println!("demo images and truth JSON written to {}", out.display());
    Ok(())
}
