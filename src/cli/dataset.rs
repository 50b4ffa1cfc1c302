//! `synthcam dataset SPEC.toml -o DIR [--shard I/N | auto] [--jobs J] [--format F,...]` and
//! `synthcam dataset merge DIR [--format F,...]`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use synthcam::dataset::generate::{generate, GenerateParams, Shard, SPEC_COPY};
use synthcam::dataset::manifest::merge_manifests;
use synthcam::dataset::spec::parse_dataset_spec_with;
use synthcam::dataset::MeshLibrary;

/// Arguments of `dataset`.
#[derive(Debug, clap::Args)]
pub struct DatasetArgs {
    /// The dataset spec (TOML; see assets/specs/), or `merge` to join and verify the shard
    /// manifests of DIR (`generate SPEC` is accepted too).
    #[arg(value_name = "SPEC|merge")]
    pub first: PathBuf,
    /// After `merge`: the dataset folder (after `generate`: the spec).
    #[arg(value_name = "DIR")]
    pub second: Option<PathBuf>,
    /// Output folder (images/, manifest, spec.toml copy).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Render only shard I of N: the images k with k % N == I (merge afterwards); `auto`: the
    /// shard of a Slurm job array or a Kubernetes Indexed Job, from the environment.
    #[arg(long, default_value = "0/1")]
    pub shard: String,
    /// Encoding and writing threads beside the render thread.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// GPU backend: auto (Vulkan, then GL), vulkan or gl.
    #[arg(long, default_value = "auto")]
    pub backend: String,
    /// Also export the finished dataset (an unsharded run, or `merge`): coco, webdataset, mcap,
    /// rosbag2, comma-separated (see `synthcam export`).
    #[arg(long, value_delimiter = ',')]
    pub format: Vec<String>,
    /// WebDataset shard size, bytes (with `--format webdataset`).
    #[arg(long, default_value_t = synthcam::dataset::formats::DEFAULT_SHARD_BYTES)]
    pub shard_bytes: u64,
    /// Also write the finished dataset (an unsharded run, or `merge`) as a rerun recording: each
    /// image with its true features and camera pose (builds with `--features rerun`).
    #[arg(long, value_name = "FILE.rrd")]
    pub rerun: Option<PathBuf>,
}

/// Export `dir` in the formats `--format` names, and as `--rerun`'s recording.
fn export_formats(dir: &Path, args: &DatasetArgs) -> anyhow::Result<()> {
    let formats = super::export::parse_formats(&args.format)?;
    let opts = synthcam::dataset::formats::ExportOptions { shard_bytes: args.shard_bytes, ..Default::default() };
    super::export::export_all(dir, &formats, None, &opts)?;
    #[cfg(feature = "rerun")]
    if let Some(path) = &args.rerun {
        super::rerun_out::dataset(path, dir)?;
    }
    Ok(())
}

/// Run `dataset`.
pub fn run(args: &DatasetArgs) -> anyhow::Result<()> {
    match (args.first.to_str(), &args.second) {
        (Some("merge"), Some(dir)) => merge(dir, args),
        (Some("merge"), None) => match &args.out {
            Some(dir) => merge(dir, args),
            None => anyhow::bail!("usage: synthcam dataset merge DIR"),
        },
        (Some("generate"), Some(spec)) => run_generate(spec, args),
        (_, None) => run_generate(&args.first, args),
        (_, Some(extra)) => anyhow::bail!("unexpected argument {} (usage: synthcam dataset SPEC.toml -o DIR | synthcam dataset merge DIR)", extra.display()),
    }
}

fn run_generate(spec_path: &Path, args: &DatasetArgs) -> anyhow::Result<()> {
    let out = args.out.as_ref().context("missing -o DIR (usage: synthcam dataset SPEC.toml -o DIR)")?;
    anyhow::ensure!(args.jobs >= 1, "--jobs must be at least 1");
    super::export::parse_formats(&args.format)?;
    super::rerun_out::check_available(args.rerun.as_deref())?;
    let text = std::fs::read_to_string(spec_path).with_context(|| format!("reading {}", spec_path.display()))?;
    let plan = parse_dataset_spec_with(&text, &MeshLibrary::beside(spec_path)).with_context(|| format!("in dataset spec {}", spec_path.display()))?;
    synthcam::dataset::poses::check_feasible(&plan).with_context(|| format!("in dataset spec {}", spec_path.display()))?;
    let renderer = super::open_renderer(&args.backend)?;
    let shard = if args.shard == "auto" { Shard::from_env(&|k| std::env::var(k).ok())? } else { args.shard.parse()? };
    let params = GenerateParams { out_dir: out.clone(), spec_text: text, shard, jobs: args.jobs };
    let bar = super::progress::bar(0, "dataset", "images");
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let report = generate(&renderer, &plan, &params, &progress).with_context(|| format!("generating into {}", out.display()))?;
    bar.finish_and_clear();
    let t = report.times;
    println!(
        "shard {}/{}: {} images ({} kept, {} rendered, {} leftover temp files removed) in {:.2} s: {:.2} images/s rendered",
        shard.index,
        shard.count,
        report.images,
        report.kept,
        report.rendered,
        report.removed_tmp,
        report.wall_s,
        report.rendered as f64 / report.wall_s.max(1e-9)
    );
    println!(
        "stage sums: prepare {:.2} s, render {:.2} s, truth {:.2} s, PNG encode {:.2} s, write {:.2} s ({} encoder threads); manifest {}",
        t.prepare_s,
        t.render_s,
        t.truth_s,
        t.encode_s,
        t.write_s,
        args.jobs,
        report.manifest.display()
    );
    if args.format.is_empty() && args.rerun.is_none() {
        Ok(())
    } else if shard.count == 1 {
        export_formats(out, args)
    } else {
        eprintln!("--format / --rerun: written once the dataset is whole: synthcam dataset merge {} [--format F] [--rerun FILE.rrd]", out.display());
        Ok(())
    }
}

fn merge(dir: &Path, args: &DatasetArgs) -> anyhow::Result<()> {
    super::export::parse_formats(&args.format)?;
    super::rerun_out::check_available(args.rerun.as_deref())?;
    let spec_path = dir.join(SPEC_COPY);
    let text = std::fs::read_to_string(&spec_path).with_context(|| format!("reading {} (is {} a dataset folder?)", spec_path.display(), dir.display()))?;
    // Only the count matters here: the copy's mesh paths may be relative to the original spec.
    let spec: synthcam::dataset::spec::DatasetSpec = toml::from_str(&text).with_context(|| format!("in {}", spec_path.display()))?;
    let report = merge_manifests(dir, spec.count).with_context(|| format!("merging {}", dir.display()))?;
    println!(
        "merged {} manifest(s) into {}: {} images, all present, SHA-256 verified",
        report.sources.len(),
        dir.join("manifest.jsonl").display(),
        report.images
    );
    export_formats(dir, args)
}
