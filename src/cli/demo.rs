//! `synthcam demo`: renders the embedded default scenes, detects their targets on the rendered
//! pixels, and reports detection against the truth labels.

use std::path::Path;

use anyhow::Context;
use nalgebra::Point2;
use synthcam::dataset::write_image_and_truth;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;
use synthcam::target::Target;

/// Run the demo into `out`.
pub fn run(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let renderer = super::open_renderer("auto")?;
    let mut report = String::from("| scene | target | render ms | found | points | error vs truth RMS px | max px |\n|---|---|---|---|---|---|---|\n");
    for (name, text) in super::DEFAULT_SCENES {
        let mut scene = parse_scene(text).with_context(|| format!("embedded scene {name}"))?;
        scene.render.noise_sigma = 1.0;
        // Warm the pipeline up (lavapipe compiles the shader on first use), then time one frame.
        renderer.render(&scene).with_context(|| format!("rendering {name}"))?;
        let t0 = std::time::Instant::now();
        let img = renderer.render(&scene).with_context(|| format!("rendering {name}"))?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let truth = truth_labels(&scene);
        let path = out.join(format!("{name}.png"));
        write_image_and_truth(&path, &img, &truth)?;
        let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
        let grey = ImageF32::from_u8(w, h, &img.to_u8())?;
        let spec = match &scene.target {
            Target::Chessboard(b) => TargetSpec::Chessboard { cols: b.inner_corner_count()[0] as usize, rows: b.inner_corner_count()[1] as usize },
            Target::DotGrid(g) => TargetSpec::DotGrid { n: g.n as usize },
            Target::SPath(s) => TargetSpec::SPath { points: s.path.points_m.len() },
        };
        let det = detect(&grey, &spec)?;
        // Dots are compared with the blob centroid, corners with the projected corner; both
        // order-agnostically (nearest truth feature).
        let truth_px: Vec<Point2<f64>> = truth.features.iter().filter(|f| f.visible).map(|f| Point2::from(f.centroid_px.unwrap_or(f.pixel_px))).collect();
        let errs: Vec<f64> = det.points_px.iter().map(|p| truth_px.iter().map(|t| (p - t).norm()).fold(f64::INFINITY, f64::min)).collect();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
        let max = errs.iter().cloned().fold(0.0, f64::max);
        println!(
            "{name}: {}x{} {} rendered in {ms:.0} ms -> {}; detected {} of {} points, error vs truth RMS {rms:.4} px (max {max:.4})",
            w,
            h,
            scene.target.kind_name(),
            path.display(),
            det.points_px.len(),
            truth_px.len()
        );
        report += &format!("| {name} | {} | {ms:.0} | {} | {}/{} | {rms:.4} | {max:.4} |\n", scene.target.kind_name(), det.found, det.points_px.len(), truth_px.len());
    }
    let report_path = out.join("report.md");
    synthcam::dataset::write_atomic(&report_path, report.as_bytes())?;
    println!("demo images, truth JSON and {} written to {}", report_path.display(), out.display());
    Ok(())
}
