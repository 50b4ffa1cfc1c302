//! `--rerun FILE.rrd` on `servo`, `sim` and `dataset`: the run or the dataset as a rerun
//! recording (`synthcam::dataset::formats::rrd`), in builds with the `rerun` feature. Without it
//! the flag is refused before any work starts, with how to get it.

use std::path::Path;

/// Check `--rerun`'s file before the run: refused in a build without the `rerun` feature (with
/// how to get it), or where the file cannot go (a directory; below a file).
pub fn check_available(path: Option<&Path>) -> anyhow::Result<()> {
    let Some(path) = path else { return Ok(()) };
    if !cfg!(feature = "rerun") {
        anyhow::bail!(
            "--rerun: this synthcam was built without rerun support; build it with `cargo build --release --features rerun` \
             (or log a run from Python: python -m synthcam.rerun_log)"
        );
    }
    anyhow::ensure!(!path.is_dir(), "--rerun {}: it is a directory", path.display());
    // The nearest existing ancestor must be a folder (missing ones are created).
    if let Some(existing) = path.ancestors().skip(1).filter(|a| !a.as_os_str().is_empty()).find(|a| a.exists()) {
        anyhow::ensure!(existing.is_dir(), "--rerun {}: {} is not a directory", path.display(), existing.display());
    }
    Ok(())
}

#[cfg(feature = "rerun")]
pub use with_rerun::*;

#[cfg(feature = "rerun")]
mod with_rerun {
    use std::path::Path;

    use anyhow::Context;
    use synthcam::dataset::formats::rrd::{self, RrdCounts};
    use synthcam::dataset::formats::FormatError;
    use synthcam::render::GreyImage;
    use synthcam::robot::Robot;
    use synthcam::sim::SimScenario;

    /// Write `path` by `write`, and say what it holds.
    fn record(path: &Path, write: impl FnOnce(&Path) -> Result<RrdCounts, FormatError>) -> anyhow::Result<()> {
        let c = write(path).with_context(|| format!("writing {}", path.display()))?;
        println!(
            "rerun: {} steps, {} frames -> {} ({:.1} MB); open it with `rerun {}`",
            c.steps,
            c.frames,
            path.display(),
            c.bytes as f64 / 1e6,
            path.display()
        );
        Ok(())
    }

    /// `servo --rerun`.
    pub fn servo(
        path: &Path,
        scenario: &SimScenario,
        robot: &dyn Robot,
        t: &synthcam::course::servo_run::ServoTrace,
        frames: &[(usize, GreyImage)],
    ) -> anyhow::Result<()> {
        record(path, |p| rrd::write_servo_rrd(p, scenario, robot, t, frames))
    }

    /// `sim --rerun`.
    pub fn sim(
        path: &Path,
        scenario: &SimScenario,
        robot: &dyn Robot,
        t: &synthcam::sim::controller::LoopTrace,
        frames: &[(usize, GreyImage)],
    ) -> anyhow::Result<()> {
        record(path, |p| rrd::write_loop_rrd(p, scenario, robot, t, frames))
    }

    /// `dataset --rerun`: the finished dataset in `dir`.
    pub fn dataset(path: &Path, dir: &Path) -> anyhow::Result<()> {
        let folder = synthcam::dataset::formats::folder::DatasetFolder::open(dir).with_context(|| format!("reading {}", dir.display()))?;
        let bar = super::super::progress::bar(folder.entries.len() as u64, "rerun", "images");
        let written = record(path, |p| rrd::write_dataset_rrd(&folder, p, &|| bar.inc(1)));
        bar.finish_and_clear();
        written
    }
}
