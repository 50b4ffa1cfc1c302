//! `synthcam export DIR --format coco|webdataset|mcap|rosbag2[,...] [-o OUT] [--shard-bytes N]`: a
//! finished dataset folder in other tools' formats (`synthcam::dataset::formats`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use synthcam::dataset::formats::bag::BagOutput;
use synthcam::dataset::formats::folder::DatasetFolder;
use synthcam::dataset::formats::{export_folder, ExportOptions, Format, DEFAULT_SHARD_BYTES};

/// Arguments of `export`.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// The dataset folder (spec.toml, manifest.jsonl, images/).
    pub dir: PathBuf,
    /// Formats, comma-separated: coco (coco.json), webdataset (webdataset/shard-NNNNNN.tar),
    /// mcap (ros2.mcap, robot-mode datasets), rosbag2 (the same bag as a folder: rosbag2/ with
    /// metadata.yaml, for `ros2 bag play`).
    #[arg(long, value_delimiter = ',', required = true)]
    pub format: Vec<String>,
    /// Output file (coco, mcap) or folder (webdataset, rosbag2) when one format is given; default
    /// inside DIR.
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// WebDataset shard size, bytes.
    #[arg(long, default_value_t = DEFAULT_SHARD_BYTES)]
    pub shard_bytes: u64,
}

/// Parse the format names (all of them before anything is written).
pub fn parse_formats(names: &[String]) -> anyhow::Result<Vec<Format>> {
    names.iter().map(|n| n.trim().parse::<Format>().map_err(anyhow::Error::from)).collect()
}

/// Export `dir` in every format of `formats`, printing one line each.
pub fn export_all(dir: &Path, formats: &[Format], out: Option<&Path>, opts: &ExportOptions) -> anyhow::Result<()> {
    anyhow::ensure!(out.is_none() || formats.len() == 1, "-o names one output: give one --format with it");
    anyhow::ensure!(opts.shard_bytes > 0, "--shard-bytes must be positive");
    let Some(first) = formats.first() else { return Ok(()) };
    let folder = DatasetFolder::open(dir).with_context(|| format!("exporting {} as {}", dir.display(), first.name()))?;
    for format in formats {
        let t0 = std::time::Instant::now();
        let bar = super::progress::bar(folder.entries.len() as u64, format.name(), "images");
        let r = export_folder(&folder, *format, out, opts, &|| bar.inc(1)).with_context(|| format!("exporting {} as {}", dir.display(), format.name()))?;
        bar.finish_and_clear();
        println!(
            "{}: {} images -> {} ({} file(s), {:.1} MB) in {:.2} s",
            format.name(),
            r.images,
            r.output.display(),
            r.files,
            r.bytes as f64 / 1e6,
            t0.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// The bags that `--mcap FILE` and `--rosbag2 DIR` ask for.
pub fn bag_outputs(mcap: Option<&Path>, rosbag2: Option<&Path>) -> Vec<BagOutput> {
    mcap.map(|p| BagOutput::File(p.to_path_buf())).into_iter().chain(rosbag2.map(|p| BagOutput::Rosbag2(p.to_path_buf()))).collect()
}

/// One line for a bag written by `servo` or `sim` (`--mcap`, `--rosbag2`).
pub fn print_bag(out: &BagOutput, counts: &synthcam::dataset::formats::mcap::McapCounts, bytes: u64) {
    println!(
        "{}: {} images, {} camera infos, {} tf messages -> {} ({:.1} MB)",
        if matches!(out, BagOutput::File(_)) { "mcap" } else { "rosbag2" },
        counts.images,
        counts.camera_infos,
        counts.tf,
        out.path().display(),
        bytes as f64 / 1e6
    );
}

/// Run `export`.
pub fn run(args: &ExportArgs) -> anyhow::Result<()> {
    let formats = parse_formats(&args.format)?;
    let opts = ExportOptions { shard_bytes: args.shard_bytes, ..ExportOptions::default() };
    export_all(&args.dir, &formats, args.out.as_deref(), &opts)
}
