//! `synthcam experiment calib-sweep [-o DIR]`: the course's calibration study, both modes.
//! `synthcam experiment robustness [-o DIR]`: the chessboard detector against camera effects.

use std::path::PathBuf;

use anyhow::Context;
use synthcam::calib::CalibModel;
use synthcam::course::sweep::{run_sweep_with, SweepMode, SweepSetup};
use synthcam::dataset::{encode_png, write_atomic};
use synthcam::render::GreyImage;
use synthcam::report::doc::Document;
use synthcam::report::sweep::{csv, plot_png, table};
use synthcam::sim::robustness::{Effect, RobustnessSetup, ViewImage};

/// Experiments.
#[derive(Debug, clap::Subcommand)]
pub enum Experiment {
    /// Intrinsic calibration error against views M and points N x N (course-scenario 1.3, 3.3).
    CalibSweep {
        /// Output folder (table.md, runs.csv, error_fx.png, report.html).
        #[arg(short, long, default_value = "out/calib-sweep")]
        out: PathBuf,
        /// Seeds per (M, N).
        #[arg(long, default_value_t = 5)]
        seeds: u64,
        /// A TOML file whose `[camera]` table (scene file, dataset spec) replaces the course camera.
        #[arg(long)]
        camera: Option<PathBuf>,
        /// Lens model to estimate (opencv4..opencv14, fisheye, double-sphere); default: the
        /// course's pinhole with distortion fixed at 0.
        #[arg(long, value_parser = |s: &str| s.parse::<CalibModel>())]
        model: Option<CalibModel>,
    },
    /// The chessboard detector against blur, defocus, sensor noise, motion blur, JPEG, a rolling
    /// shutter, a lamp's gradient, a glossy board's highlight and a cluttered background, one at a
    /// time at rising strength, errors against the exact truth.
    Robustness {
        /// Output folder (table.md, runs.csv, <effect>.png, report.html, images/).
        #[arg(short, long, default_value = "out/robustness")]
        out: PathBuf,
        /// Poses per level (view 0: assets/scenes/chessboard_k1.toml; the others perturbed).
        #[arg(long, default_value_t = 6)]
        views: usize,
        /// Comma-separated effects (blur, defocus, noise, motion-blur, jpeg, rolling-shutter,
        /// gradient, highlight, clutter, shadow); default all.
        #[arg(long)]
        effects: Option<String>,
        /// Write every image with its truth JSON and a `.truth.json` sidecar under
        /// OUT/images/<effect>/ (for benches/robustness_opencv.py); `--images false` to skip.
        #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
        images: bool,
        /// Seed of the pose perturbations and the noise.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
}

/// The sweep's camera and model from the command line.
fn setup(camera: Option<&PathBuf>, model: Option<CalibModel>) -> anyhow::Result<SweepSetup> {
    let mut s = SweepSetup { model, ..Default::default() };
    if let Some(path) = camera {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        #[derive(serde::Deserialize)]
        struct File {
            camera: synthcam::scene::file::CameraSpec,
        }
        let f: File = toml::from_str(&text).with_context(|| format!("{}: no valid [camera] table", path.display()))?;
        s.camera = f.camera.to_model().with_context(|| format!("{}: [camera]", path.display()))?;
    }
    Ok(s)
}

/// Run an experiment.
pub fn run(e: &Experiment) -> anyhow::Result<()> {
    match e {
        Experiment::CalibSweep { out, seeds, camera, model } => {
            let setup = setup(camera.as_ref(), *model)?;
            std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
            let ms = [3, 5, 10, 20, 40];
            let ns = [3, 5, 7, 9];
            let renderer = super::open_renderer("auto")?;
            let sweep = |mode: SweepMode, renderer: Option<&synthcam::render::Renderer>| {
                let (t0, name) = (std::time::Instant::now(), if renderer.is_some() { "rendered" } else { "ideal" });
                let bar = super::progress::bar(ns.len() as u64 * *seeds, name, "view pools");
                let runs = run_sweep_with(&setup, mode, &ms, &ns, *seeds, renderer, &mut |done, _| bar.set_position(done as u64));
                bar.finish_and_clear();
                eprintln!("{name} mode: {} calibrations in {:.1} s", runs.as_ref().map_or(0, Vec::len), t0.elapsed().as_secs_f64());
                runs
            };
            let mut runs = sweep(SweepMode::Ideal, None)?;
            runs.extend(sweep(SweepMode::Rendered, Some(&renderer))?);
            let table = table(&runs, &ms, &ns);
            write_atomic(&out.join("table.md"), table.markdown().as_bytes())?;
            write_atomic(&out.join("runs.csv"), csv(&runs).as_bytes())?;
            let plot = plot_png(&runs, &ms, &ns)?;
            write_atomic(&out.join("error_fx.png"), &plot)?;
            println!("{}", table.markdown());
            let mut doc = Document::new("Calibration sweep: intrinsic error against views M and points N x N");
            doc.paragraph(format!("Mean +- std over {seeds} seeds per (mode, M, N); %e = percent error of the estimate against the truth."));
            doc.table(table).image("mean % error of fx against M", Some("error_fx.png".into()), plot);
            super::write_document(out, None, &doc)?;
            println!("wrote table.md, runs.csv, error_fx.png and report.html to {}", out.display());
            Ok(())
        }
        Experiment::Robustness { out, views, effects, images, seed } => robustness(out, *views, effects.as_deref(), *images, *seed),
    }
}

/// The effects named in a comma list (all when `None`).
fn parse_effects(list: Option<&str>) -> anyhow::Result<Vec<Effect>> {
    let Some(list) = list else { return Ok(Effect::ALL.to_vec()) };
    let names: Vec<&str> = Effect::ALL.iter().map(Effect::name).collect();
    list.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| Effect::from_name(s).with_context(|| format!("unknown effect `{s}` (one of {})", names.join(", "))))
        .collect()
}

/// Write one view's image (PNG), truth JSON and the sidecar with the truth the detector is
/// compared with (`<level>_<view>.truth.json`).
fn write_view(dir: &std::path::Path, v: &ViewImage<'_>) -> anyhow::Result<()> {
    let effect = v.run.effect;
    let folder = dir.join(effect.name());
    std::fs::create_dir_all(&folder).with_context(|| format!("creating {}", folder.display()))?;
    let stem = format!("{:02}_{:02}", v.level_index, v.run.view);
    synthcam::dataset::write_image_and_truth(&folder.join(format!("{stem}.png")), v.image, v.truth)?;
    let num = |x: f64| if x.is_finite() { serde_json::json!(x) } else { serde_json::Value::Null };
    let sidecar = serde_json::json!({
        "effect": effect.name(),
        "level_index": v.level_index,
        "level": synthcam::report::robustness::level_label(v.run.level),
        "strength": num(v.run.strength),
        "view": v.run.view,
        "grid": v.grid,
        "truth_px": v.truth_px.iter().map(|p| [num(p[0]), num(p[1])]).collect::<Vec<_>>(),
        "synthcam": { "detected": v.run.detected, "rms_px": num(v.run.rms_px), "max_px": num(v.run.max_px) },
    });
    write_atomic(&folder.join(format!("{stem}.truth.json")), &serde_json::to_vec_pretty(&sidecar)?)?;
    Ok(())
}

/// `experiment robustness`.
fn robustness(out: &std::path::Path, views: usize, effects: Option<&str>, images: bool, seed: u64) -> anyhow::Result<()> {
    use synthcam::report::robustness::{csv, level_label, plot_png, table};
    let effects = parse_effects(effects)?;
    anyhow::ensure!(views >= 1 && !effects.is_empty(), "needs at least one view and one effect");
    let setup = RobustnessSetup::chessboard_k1(views, seed)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let renderer = super::open_renderer("auto")?;
    let (t0, image_dir) = (std::time::Instant::now(), out.join("images"));
    let mut found = 0;
    let bar = super::progress::bar((effects.iter().map(|e| e.levels().len()).sum::<usize>() * views) as u64, "robustness", "images");
    // View 0 at each effect's weakest and strongest level, for the report.
    let mut frames: Vec<(Effect, usize, String, GreyImage)> = Vec::new();
    let runs = synthcam::sim::robustness::run_robustness(&renderer, &setup, &effects, &mut |v| {
        found += usize::from(v.run.detected);
        bar.inc(1);
        if v.run.view == 0 {
            let (e, level) = (v.run.effect, level_label(v.run.level));
            let frame = (e, v.level_index, format!("{} {level} {}, view 0 (found: {})", e.name(), e.level_name(), v.run.detected), v.image.clone());
            match frames.last_mut() {
                Some(last) if last.0 == e && last.1 > 0 => *last = frame,
                _ => frames.push(frame),
            }
        }
        if v.run.view + 1 == views {
            bar.suspend(|| eprintln!("{} {}: {found}/{views} found ({:.1} s)", v.run.effect.name(), level_label(v.run.level), t0.elapsed().as_secs_f64()));
            found = 0;
        }
        if images {
            write_view(&image_dir, v).map_err(|e| format!("{e:#}"))?;
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    eprintln!("{} images in {:.1} s", runs.len(), t0.elapsed().as_secs_f64());
    let table = table(&runs);
    write_atomic(&out.join("table.md"), table.markdown().as_bytes())?;
    write_atomic(&out.join("runs.csv"), csv(&runs).as_bytes())?;
    println!("{}", table.markdown());
    let mut doc = Document::new("Robustness of the chessboard detector");
    doc.paragraph(format!("{views} views per level, seed {seed}; errors against the exact truth of the rendered corners."));
    doc.table(table);
    for e in &effects {
        let (file, png) = (format!("{}.png", e.name()), plot_png(&runs, *e)?);
        write_atomic(&out.join(&file), &png)?;
        doc.image(format!("{}: mean RMS corner error and detection rate against the strength", e.name()), Some(file), png);
    }
    doc.heading(2, "Frames: view 0 at the weakest and the strongest level");
    for (.., caption, img) in frames {
        doc.image(caption, None, encode_png(&img)?);
    }
    super::write_document(out, None, &doc)?;
    println!("wrote table.md, runs.csv, one plot per effect and report.html to {}", out.display());
    Ok(())
}
