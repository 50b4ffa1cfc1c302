//! `synthcam sim SCENARIO.toml [--law pbvs|ibvs] [--views N] [--ideal] [--json OUT] [--mcap BAG] [--rerun RRD]`:
//! an open scenario (any camera, target and robot): hand-eye from rendered views, then the law.

use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;

use anyhow::Context;
use synthcam::dataset::write_atomic;
use synthcam::render::GreyImage;
use synthcam::scene::Scene;
use synthcam::sim::controller::Law;
use synthcam::sim::open_run::{run_open, OpenRunOptions};
use synthcam::sim::sensor::{Capture, IdealSensor, RenderedSensor, Sensor};
use synthcam::sim::{ScenarioSpec, Sim};

/// Noise of the ideal projections, pixels (the course's).
const IDEAL_NOISE_PX: f64 = 0.1;

/// Arguments of `sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// Scenario file (TOML), e.g. assets/scenarios/ur5e_chessboard.toml.
    pub scenario: PathBuf,
    /// Control law: pbvs or ibvs.
    #[arg(long, default_value = "pbvs")]
    pub law: String,
    /// Hand-eye views before the loop (0: the true hand-eye).
    #[arg(long, default_value_t = 10)]
    pub views: usize,
    /// Control steps at most.
    #[arg(long, default_value_t = 300)]
    pub steps: usize,
    /// Ideal projections + 0.1 px noise instead of rendered + detected.
    #[arg(long)]
    pub ideal: bool,
    /// Write the run (hand-eye error, every step) as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the loop's rendered frames as a ROS 2 bag (MCAP: Image, CameraInfo, /tf).
    #[arg(long)]
    pub mcap: Option<PathBuf>,
    /// Write the same bag as a rosbag2 folder (metadata.yaml + MCAP), for `ros2 bag play DIR`.
    #[arg(long, value_name = "DIR")]
    pub rosbag2: Option<PathBuf>,
    /// Write the loop as a rerun recording (every frame, features, poses, joints, commands and
    /// errors; builds with `--features rerun`).
    #[arg(long, value_name = "FILE.rrd")]
    pub rerun: Option<PathBuf>,
}

/// Frames kept by [`Recording`]: (simulator frame, image).
type Frames = Rc<RefCell<Vec<(usize, GreyImage)>>>;

/// A sensor that keeps every image it captures (the k-th capture is the simulator's frame k).
struct Recording<'a> {
    inner: Box<dyn Sensor + 'a>,
    frames: Frames,
}

impl Sensor for Recording<'_> {
    fn capture(&mut self, scene: &Scene) -> Result<Capture, synthcam::sim::SimError> {
        let c = self.inner.capture(scene)?;
        let mut frames = self.frames.borrow_mut();
        if let Some(img) = &c.image {
            let k = frames.len();
            frames.push((k, img.clone()));
        }
        Ok(c)
    }
}

/// Run `sim`.
pub fn run(args: &SimArgs) -> anyhow::Result<()> {
    let law = match args.law.as_str() {
        "pbvs" => Law::Pbvs,
        "ibvs" => Law::Ibvs,
        other => anyhow::bail!("--law must be pbvs or ibvs, got {other}"),
    };
    let text = std::fs::read_to_string(&args.scenario).with_context(|| format!("reading {}", args.scenario.display()))?;
    let spec = ScenarioSpec::parse(&text).with_context(|| format!("in scenario {}", args.scenario.display()))?;
    let base = args.scenario.parent().map(PathBuf::from).unwrap_or_default();
    let robot = spec.robot.build(&|p| std::fs::read_to_string(base.join(p)).map_err(|e| e.to_string()))?;
    let meshes = synthcam::dataset::MeshLibrary::beside(&args.scenario);
    let scenario = spec.to_scenario_with(&|p: &str| meshes.load(p))?;
    let bags = super::export::bag_outputs(args.mcap.as_deref(), args.rosbag2.as_deref());
    anyhow::ensure!(
        !args.ideal || (bags.is_empty() && args.rerun.is_none()),
        "--mcap / --rosbag2 / --rerun record rendered frames: they cannot go with --ideal"
    );
    super::rerun_out::check_available(args.rerun.as_deref())?;
    let renderer = if args.ideal { None } else { Some(super::open_renderer("auto")?) };
    let sensor: Box<dyn Sensor> = match &renderer {
        Some(r) => Box::new(RenderedSensor::new(r)),
        None => Box::new(IdealSensor::new(IDEAL_NOISE_PX, 0)?),
    };
    let frames = Frames::default();
    let sensor: Box<dyn Sensor> = if !bags.is_empty() || args.rerun.is_some() { Box::new(Recording { inner: sensor, frames: frames.clone() }) } else { sensor };
    let mut sim = Sim::new(scenario.clone(), robot, sensor)?;
    // Ideal features carry N(0, sigma^2) per coordinate: their RMS distance to the desired ones
    // cannot fall below sigma sqrt(2), so the IBVS stop is raised to 2 sigma there.
    let stop_px = if args.ideal { 2.0 * IDEAL_NOISE_PX } else { 0.05 };
    let run = run_open(&mut sim, &OpenRunOptions { law, handeye_views: args.views, max_steps: args.steps, stop_px, ..Default::default() })?;
    let (mm, deg) = run.handeye_error_mm_deg;
    println!("robot {}: hand-eye tool_from_cam error {mm:.4} mm {deg:.5} deg ({} views)", sim.robot().name(), args.views);
    let last = run.trace.steps.last().map(|s| s.goal_error_mm_deg).unwrap_or_default();
    println!(
        "{}: {} steps, {}; camera vs goal {:.4} mm {:.5} deg{}",
        args.law,
        run.trace.steps.len(),
        if run.trace.stopped { "converged" } else { "step limit reached" },
        last.0,
        last.1,
        run.final_pixel_rms_px.map(|p| format!(", pixel RMS {p:.4} px")).unwrap_or_default()
    );
    if let Some(p) = &args.json {
        write_atomic(p, &serde_json::to_vec_pretty(&run)?)?;
    }
    for bag in &bags {
        let (counts, bytes) = synthcam::dataset::formats::series::write_loop_bag(bag, &scenario, sim.robot(), &run.trace, &frames.borrow())
            .with_context(|| format!("writing {}", bag.path().display()))?;
        super::export::print_bag(bag, &counts, bytes);
    }
    #[cfg(feature = "rerun")]
    if let Some(path) = &args.rerun {
        super::rerun_out::sim(path, &scenario, sim.robot(), &run.trace, &frames.borrow())?;
    }
    anyhow::ensure!(run.trace.stopped, "the loop did not converge in {} steps", args.steps);
    Ok(())
}
