//! `synthcam bench`: median render + readback time of the embedded scenes, the figure the
//! renderer's speed goals are stated in (first frames excluded: lavapipe compiles the shader then).

use anyhow::Context;
use synthcam::scene::file::parse_scene_with;

/// Arguments of `bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Timed frames per scene.
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
    /// GPU backend: auto, vulkan or gl.
    #[arg(long, default_value = "auto")]
    pub backend: String,
    /// Also time the closed IBVS loop from the course's start for this many steps (render +
    /// detect + law every step, no early stop), e.g. 200.
    #[arg(long)]
    pub servo_steps: Option<usize>,
    /// Also time the chessboard scene with a 100 820-triangle icosphere in front of it (issue 19's
    /// speed goal: <= 100 ms on lavapipe).
    #[arg(long)]
    pub mesh: bool,
    /// The table of issue 42 instead: frames/s of the chessboard, ChArUco, S-path, fisheye, mesh
    /// and effects scenes at 1280 x 1024 and 3840 x 3072, dataset images/s and servo steps/s, with
    /// the adapter's name (`benches/gpu.sh` runs it on lavapipe and on the GPU and compares).
    #[arg(long)]
    pub report: bool,
    /// With --report: keep every scene's image and report.json in this folder.
    #[arg(long, value_name = "DIR", requires = "report")]
    pub out: Option<std::path::PathBuf>,
    /// With --report: compare the images with another run's --out folder (max difference, pixels).
    #[arg(long, value_name = "DIR", requires = "report")]
    pub compare: Option<std::path::PathBuf>,
    /// Scene files to time instead of the embedded scenes.
    pub scenes: Vec<std::path::PathBuf>,
}

/// Time `frames` renders of `scene` (after 3 untimed) and print the medians.
fn time_scene(renderer: &synthcam::render::Renderer, name: &str, scene: &synthcam::scene::Scene, frames: usize) -> anyhow::Result<()> {
    use super::bench_report::{percentile, time_frames};
    let (render_ms, post_ms, _) = time_frames(renderer, scene, frames)?;
    println!(
        "{name:>14} {}x{}: render+readback median {:.1} ms (p10 {:.1}, p90 {:.1}); quantise+PNG median {:.1} ms; {} frames",
        scene.camera.size.width,
        scene.camera.size.height,
        percentile(&render_ms, 0.5),
        percentile(&render_ms, 0.1),
        percentile(&render_ms, 0.9),
        percentile(&post_ms, 0.5),
        render_ms.len()
    );
    Ok(())
}

/// The course's IBVS loop from its start for `steps` steps (no early stop, true hand-eye).
///
/// # Errors
/// The loop's.
pub fn ibvs_loop(renderer: &synthcam::render::Renderer, steps: usize) -> anyhow::Result<synthcam::course::servo_run::ServoTrace> {
    use synthcam::course::servo_run::{run_servo, HandEyeSource, ServoOptions, ServoScenario};
    use synthcam::sim::controller::Law;
    let mut o = ServoOptions::new(Law::Ibvs);
    o.max_steps = steps;
    o.stop = None;
    o.handeye = HandEyeSource::Truth;
    run_servo(Some(renderer), &ServoScenario::default(), &o, &mut |_, _| {}).context("IBVS loop")
}

/// Run the benchmark.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let renderer = super::open_renderer(&args.backend)?;
    if args.report {
        anyhow::ensure!(args.scenes.is_empty() && !args.mesh, "--report times its own scenes (the mesh scene included): drop the scene files and --mesh");
        let opts = super::bench_report::ReportOptions {
            frames: args.frames,
            dataset_images: 40,
            servo_steps: args.servo_steps.unwrap_or(50),
            out: args.out.clone(),
            compare: args.compare.clone(),
        };
        return super::bench_report::run(&renderer, &opts);
    }
    println!("threads: LP_NUM_THREADS={}", std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "(default)".into()));
    let mut list: Vec<(String, String)> = Vec::new();
    let meshes = synthcam::dataset::MeshLibrary::new(std::path::Path::new("."));
    for path in &args.scenes {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        list.push((path.display().to_string(), text));
    }
    if list.is_empty() {
        list = super::DEFAULT_SCENES.iter().map(|(n, t)| ((*n).to_string(), (*t).to_string())).collect();
    }
    let mut scenes = Vec::new();
    for (name, text) in &list {
        scenes.push((name.clone(), parse_scene_with(text, &meshes).with_context(|| format!("scene {name}"))?));
    }
    if args.mesh {
        let board = super::DEFAULT_SCENES.iter().find(|(n, _)| *n == "chessboard_k1").map_or("", |(_, t)| *t);
        scenes.push((
            "chessboard_k1+mesh100k".into(),
            synthcam::scene::objects::with_benchmark_mesh(synthcam::scene::file::parse_scene(board)).context("mesh scene")?,
        ));
    }
    for (name, scene) in &scenes {
        time_scene(&renderer, name, scene, args.frames)?;
    }
    if let Some(steps) = args.servo_steps {
        let t = ibvs_loop(&renderer, steps)?;
        let (r, d, l) = t.time_split_ms();
        let n = t.steps.len().max(1) as f64;
        println!(
            "IBVS loop, {} steps ({}): {:.2} s wall; render {:.2} s ({:.1} ms/step), detect {:.2} s ({:.1} ms/step), law {:.3} s ({:.2} ms/step); final pixel RMS {:.3} px",
            t.steps.len(),
            t.status.describe(),
            t.loop_s,
            r * 1e-3,
            r / n,
            d * 1e-3,
            d / n,
            l * 1e-3,
            l / n,
            t.last().map_or(f64::NAN, |s| s.pixel_rms_px)
        );
    }
    Ok(())
}
