//! `synthcam experiment calib-sweep [-o DIR]`: the course's calibration study, both modes.

use std::path::PathBuf;

use anyhow::Context;
use synthcam::calib::CalibModel;
use synthcam::dataset::write_atomic;
use synthcam::report::sweep::{csv, markdown, plot_png};
use synthcam::sim::sweep::{run_sweep_with, SweepMode, SweepSetup};

/// Experiments.
#[derive(Debug, clap::Subcommand)]
pub enum Experiment {
    /// Intrinsic calibration error against views M and points N x N (course-scenario 1.3, 3.3).
    CalibSweep {
        /// Output folder (table.md, runs.csv, error_fx.png).
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
            let t0 = std::time::Instant::now();
            let mut runs = run_sweep_with(&setup, SweepMode::Ideal, &ms, &ns, *seeds, None)?;
            eprintln!("ideal mode: {} calibrations in {:.1} s", runs.len(), t0.elapsed().as_secs_f64());
            let t1 = std::time::Instant::now();
            runs.extend(run_sweep_with(&setup, SweepMode::Rendered, &ms, &ns, *seeds, Some(&renderer))?);
            eprintln!("rendered mode: {:.1} s", t1.elapsed().as_secs_f64());
            let table = markdown(&runs, &ms, &ns);
            write_atomic(&out.join("table.md"), table.as_bytes())?;
            write_atomic(&out.join("runs.csv"), csv(&runs).as_bytes())?;
            write_atomic(&out.join("error_fx.png"), &plot_png(&runs, &ms, &ns)?)?;
            println!("{table}");
            println!("wrote table.md, runs.csv and error_fx.png to {}", out.display());
            Ok(())
        }
    }
}
