//! The command line: a thin adapter that parses, loads, calls the library and writes.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

mod bench;
mod bench_report;
mod calibrate;
mod dataset;
mod demo;
mod detect;
mod experiment;
mod export;
mod handeye;
mod progress;
mod render;
mod rerun_out;
mod scenario_file;
mod servo;
mod sim;
mod skipped;

/// synthcam: synthetic camera images with exact ground truth for calibration and visual servoing.
#[derive(Debug, Parser)]
#[command(version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: CliCommand,
}

/// Subcommands, alphabetical.
#[derive(Debug, Subcommand)]
pub enum CliCommand {
    /// Time the renderer (render + readback) on the embedded scenes.
    Bench(bench::BenchArgs),
    /// Detect a target's points in images (files or folders) and print or write them as JSON.
    ///
    /// SYNOPSIS: synthcam detect ../shared/data/opencv_left --target chessboard:9x6 --json corners.json
    Detect(detect::DetectArgs),
    /// Calibrate a camera from chessboard images or a detections JSON.
    ///
    /// SYNOPSIS: synthcam calibrate ../shared/data/opencv_left --target chessboard:9x6 --square 0.025 --json calib.json
    Calibrate(calibrate::CalibrateArgs),
    /// Generate a dataset from a spec (sharded, resumable), or merge and verify a sharded one.
    ///
    /// SYNOPSIS: synthcam dataset assets/specs/chessboard_1280.toml -o DIR [--shard I/N] [--jobs J]
    ///           synthcam dataset merge DIR [--format coco,webdataset,mcap,rosbag2]
    /// Shard I/N renders the images k with k % N == I. `--format` exports the finished dataset
    /// (after an unsharded run, or at `merge`) as `synthcam export` does.
    Dataset(dataset::DatasetArgs),
    /// Run the main job on the embedded default scenario and write a report folder.
    Demo {
        /// Output folder.
        #[arg(short, long, default_value = "out/demo")]
        out: PathBuf,
    },
    /// Reproduce the course's experiments (calib-sweep).
    #[command(subcommand)]
    Experiment(experiment::Experiment),
    /// Export a finished dataset folder in other tools' formats.
    ///
    /// SYNOPSIS: synthcam export DIR --format coco[,webdataset,mcap,rosbag2] [-o OUT] [--shard-bytes N]
    /// coco: DIR/coco.json, COCO keypoints (pixel_px unchanged, OpenCV pixel centres; v 2/1/0).
    /// webdataset: DIR/webdataset/shard-000000.tar, ... (NNNNNN.png + NNNNNN.json, ~1 GB each).
    /// mcap: DIR/ros2.mcap, a ROS 2 bag (Image, CameraInfo, /tf) of a robot-mode dataset.
    /// rosbag2: DIR/rosbag2/ (metadata.yaml + rosbag2_0.mcap), the same bag for `ros2 bag play`.
    Export(export::ExportArgs),
    /// The course's hand-eye experiment (variant A) on rendered and detected pixels.
    ///
    /// SYNOPSIS: synthcam handeye --views 5 --seed 0   (prints estimated vs true transforms)
    Handeye(handeye::HandEyeArgs),
    /// Render a scene file (TOML or JSON) to a PNG and its truth JSON.
    ///
    /// SYNOPSIS: synthcam render assets/scenes/chessboard_k1.toml -o board.png
    /// writes board.png and board.json (camera, pose, every corner's exact pixel).
    Render(render::RenderArgs),
    /// Visual servoing (PBVS or IBVS) in the loop: render, detect and control at every step.
    ///
    /// SYNOPSIS: synthcam servo --law ibvs -o out/ibvs --frames
    /// writes trace.csv/json, trace_ideal.csv/json, plots, summary.md (error budget) and report.html;
    /// `--mcap run.mcap` writes the rendered frames as a ROS 2 bag (Image, CameraInfo, /tf),
    /// `--rosbag2 DIR` the same as a rosbag2 folder (`ros2 bag play DIR`).
    Servo(servo::ServoArgs),
    /// An open scenario (any camera, target and robot): hand-eye from rendered views, then PBVS or IBVS.
    ///
    /// SYNOPSIS: synthcam sim assets/scenarios/ur5e_chessboard.toml --law ibvs --json run.json [--mcap run.mcap] [--rosbag2 DIR]
    Sim(sim::SimArgs),
}

/// Run a parsed command line.
///
/// # Errors
/// Whatever the subcommand reports; `main` prints the chain and exits non-zero.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        CliCommand::Bench(args) => bench::run(&args),
        CliCommand::Calibrate(args) => calibrate::run(&args),
        CliCommand::Dataset(args) => dataset::run(&args),
        CliCommand::Demo { out } => demo::run(&out),
        CliCommand::Detect(args) => detect::run(&args),
        CliCommand::Experiment(e) => experiment::run(&e),
        CliCommand::Export(args) => export::run(&args),
        CliCommand::Handeye(args) => handeye::run(&args),
        CliCommand::Render(args) => render::run(&args),
        CliCommand::Servo(args) => servo::run(&args),
        CliCommand::Sim(args) => sim::run(&args),
    }
}

/// Embedded default scenes: (name, TOML text).
pub const DEFAULT_SCENES: [(&str, &str); 2] =
    [("course_s_path", include_str!("../../assets/scenes/course_s_path.toml")), ("chessboard_k1", include_str!("../../assets/scenes/chessboard_k1.toml"))];

/// Write `doc` as `dir/report.html` and, when `markdown` names a file, as markdown there too
/// (both atomically; `dir` is created).
pub fn write_document(dir: &std::path::Path, markdown: Option<&str>, doc: &synthcam::report::doc::Document) -> anyhow::Result<()> {
    use anyhow::Context;
    use synthcam::dataset::write_atomic;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    if let Some(name) = markdown {
        write_atomic(&dir.join(name), doc.markdown().as_bytes())?;
    }
    write_atomic(&dir.join("report.html"), synthcam::report::html::page(doc).as_bytes())?;
    Ok(())
}

/// Open the GPU on the chosen backend and build a renderer, logging the adapter.
pub fn open_renderer(backend: &str) -> anyhow::Result<synthcam::render::Renderer> {
    use anyhow::Context;
    use synthcam::render::{BackendChoice, Renderer};
    let choice = match backend {
        "auto" => BackendChoice::Auto,
        "vulkan" => BackendChoice::Vulkan,
        "gl" => BackendChoice::Gl,
        other => anyhow::bail!("unknown backend `{other}` (auto, vulkan, gl)"),
    };
    let renderer = Renderer::with_backend(choice).context("opening the GPU")?;
    eprintln!("adapter: {}", renderer.context().describe());
    Ok(renderer)
}
