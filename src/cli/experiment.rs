//! `synthcam experiment calib-sweep [-o DIR]`: the course's calibration study, both modes.

use std::path::PathBuf;

use anyhow::Context;
use synthcam::dataset::write_atomic;
use synthcam::report::sweep::{csv, markdown, plot_png};
use synthcam::sim::sweep::{run_sweep, SweepMode};

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
    },
}

/// Run an experiment.
pub fn run(e: &Experiment) -> anyhow::Result<()> {
    match e {
        Experiment::CalibSweep { out, seeds } => {
            std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
            let ms = [3, 5, 10, 20, 40];
            let ns = [3, 5, 7, 9];
            let renderer = super::open_renderer("auto")?;
            let t0 = std::time::Instant::now();
            let mut runs = run_sweep(SweepMode::Ideal, &ms, &ns, *seeds, None)?;
            eprintln!("ideal mode: {} calibrations in {:.1} s", runs.len(), t0.elapsed().as_secs_f64());
            let t1 = std::time::Instant::now();
            runs.extend(run_sweep(SweepMode::Rendered, &ms, &ns, *seeds, Some(&renderer))?);
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
