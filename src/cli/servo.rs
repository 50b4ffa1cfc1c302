//! `synthcam servo --law pbvs|ibvs [--scenario S] [--steps N] [-o DIR] [--frames]`: the closed
//! loop on rendered and detected pixels, next to the same loop on ideal projections + noise, with
//! traces (CSV, JSON), plots and the error budget.

use std::path::{Path, PathBuf};

use anyhow::Context;
use synthcam::course::servo_run::{run_servo_on, HandEyeSource, ServoOptions, ServoScenario, ServoTrace};
use synthcam::dataset::formats::bag::BagOutput;
use synthcam::dataset::{encode_png, write_atomic};
use synthcam::render::GreyImage;
use synthcam::report::doc::Document;
use synthcam::report::servo::{budget_table, contact_sheet, csv, error_png, path_png, singular_png, tracks_png};
use synthcam::servo::InteractionFrom;
use synthcam::sim::controller::Law;
use synthcam::sim::sensor::ObservationKind;
use synthcam::sim::{RobotSpec, SimScenario};

use super::scenario_file::ScenarioFile;

/// The law on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LawArg {
    /// Position-based.
    Pbvs,
    /// Image-based.
    Ibvs,
}

/// The interaction matrix on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InteractionArg {
    /// At the current pose estimate (the course).
    Current,
    /// At the desired pose.
    Desired,
    /// Mean of both.
    Mean,
}

/// Arguments of `servo`.
#[derive(Debug, clap::Args)]
pub struct ServoArgs {
    /// Control law.
    #[arg(long, value_enum)]
    pub law: LawArg,
    /// Scenario (TOML; default: the course, assets/scenarios/servo_course.toml).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Maximum control steps (default: PBVS 100, IBVS 300; with --course 30 / 200).
    #[arg(long)]
    pub steps: Option<usize>,
    /// Output folder (default out/servo-<law>).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Save every rendered frame and a contact sheet.
    #[arg(long)]
    pub frames: bool,
    /// Run only on ideal projections + noise (no renderer).
    #[arg(long)]
    pub ideal: bool,
    /// Skip the ideal-projection comparison run.
    #[arg(long)]
    pub no_compare: bool,
    /// Use the true hand-eye transforms instead of estimating them from 5 views.
    #[arg(long)]
    pub true_handeye: bool,
    /// The course's law exactly: constant IBVS gain 0.03, 30 / 200 steps, no early stop.
    #[arg(long)]
    pub course: bool,
    /// Run every step (no early stop).
    #[arg(long)]
    pub no_stop: bool,
    /// IBVS interaction matrix.
    #[arg(long, value_enum, default_value_t = InteractionArg::Current)]
    pub interaction: InteractionArg,
    /// IBVS damping of the least squares, px^2 (default 100, course 0.1).
    #[arg(long)]
    pub damping: Option<f64>,
    /// Seed of the hand-eye views and all noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Also write the rendered run as a ROS 2 bag in MCAP: /cam0/image_raw, /cam0/camera_info,
    /// /tf (world -> base -> tool0 -> cam0, world -> target), step s at s x 100 ms.
    #[arg(long, value_name = "PATH")]
    pub mcap: Option<PathBuf>,
    /// Also write that bag as a rosbag2 folder (metadata.yaml + MCAP), for `ros2 bag play DIR`.
    #[arg(long, value_name = "DIR")]
    pub rosbag2: Option<PathBuf>,
    /// Write the rendered run as a rerun recording (every frame, the detected, true and desired
    /// features, the camera's pose and frustum, joints and errors; builds with `--features rerun`).
    #[arg(long, value_name = "FILE.rrd")]
    pub rerun: Option<PathBuf>,
}

fn options(args: &ServoArgs, observation: ObservationKind) -> ServoOptions {
    let law = if args.law == LawArg::Pbvs { Law::Pbvs } else { Law::Ibvs };
    let mut o = ServoOptions::new(law);
    o.observation = observation;
    o.seed = args.seed;
    if args.course {
        o.ibvs = synthcam::course::ibvs_params();
        o.max_steps = if law == Law::Pbvs { 30 } else { 200 };
        o.stop = None;
    }
    if args.no_stop {
        o.stop = None;
    }
    if let Some(n) = args.steps {
        o.max_steps = n;
    }
    o.ibvs.interaction = match args.interaction {
        InteractionArg::Current => InteractionFrom::Current,
        InteractionArg::Desired => InteractionFrom::Desired,
        InteractionArg::Mean => InteractionFrom::Mean,
    };
    if let Some(d) = args.damping {
        o.ibvs.damping = d;
    }
    if args.true_handeye {
        o.handeye = HandEyeSource::Truth;
    }
    o
}

/// Write `stem.csv` and `stem.json` of `trace` into `out`.
///
/// # Errors
/// Serialisation or writing failed.
pub fn write_trace(out: &Path, stem: &str, trace: &ServoTrace) -> anyhow::Result<()> {
    write_atomic(&out.join(format!("{stem}.csv")), csv(trace).as_bytes())?;
    write_atomic(&out.join(format!("{stem}.json")), &serde_json::to_vec(trace)?)?;
    Ok(())
}

fn print_run(name: &str, t: &ServoTrace) {
    let (r, d, l) = t.time_split_ms();
    match t.last() {
        Some(s) => println!(
            "{name}: {} after {} updates; camera {:.3} mm / {:.4} deg from the desired pose, pixel error RMS {:.3} px (max {:.3}); loop {:.2} s (render {:.2} s, detect {:.2} s, law {:.2} s), hand-eye {:.1} s",
            t.status.describe(),
            t.updates,
            s.pose_error_mm,
            s.pose_error_deg,
            s.pixel_rms_px,
            s.pixel_max_px,
            t.loop_s,
            r * 1e-3,
            d * 1e-3,
            l * 1e-3,
            t.handeye_s
        ),
        None => println!("{name}: {}", t.status.describe()),
    }
}

/// A picture for the report: (caption, link for the markdown, PNG bytes).
pub type Picture = (String, Option<String>, Vec<u8>);

/// Write the plots, `summary.md` and `report.html` (the error budget of `traces` side by side,
/// the plots, then `frames`) into `out`; returns the report.
///
/// # Errors
/// Encoding or writing failed.
pub fn write_report(out: &Path, law_name: &str, traces: &[(&str, ServoTrace)], image_size: (u32, u32), frames: Vec<Picture>) -> anyhow::Result<Document> {
    let refs: Vec<(&str, &ServoTrace)> = traces.iter().map(|(n, t)| (*n, t)).collect();
    anyhow::ensure!(!refs.is_empty(), "no servo run to report");
    let mut doc = Document::new(format!("{} from the scenario's start", law_name.to_uppercase()));
    doc.table(budget_table(&refs));
    doc.paragraph("Traces: trace.csv / trace.json per step (trace_ideal.* for the ideal run).");
    let plots = [
        ("error.png", "error per step", error_png(&refs)?),
        ("feature_tracks.png", "feature tracks", tracks_png(refs[0].1, image_size.0, image_size.1)?),
        ("camera_path.png", "camera path", path_png(&refs)?),
        ("singular_values.png", "singular values", singular_png(&refs)?),
    ];
    for (file, alt, png) in plots {
        write_atomic(&out.join(file), &png)?;
        doc.image(alt, Some(file.to_string()), png);
    }
    for (alt, link, png) in frames {
        doc.image(alt, link, png);
    }
    super::write_document(out, Some("summary.md"), &doc)?;
    Ok(doc)
}

/// The rendered run's frames: written under `frames/` with `--frames` (every tenth a thumbnail
/// of the contact sheet), the first and the last kept for the report.
#[derive(Default)]
struct FrameSink {
    /// `frames/` when `--frames`.
    dir: Option<PathBuf>,
    thumbs: Vec<(usize, image::GrayImage)>,
    first: Option<(usize, GreyImage)>,
    last: Option<(usize, GreyImage)>,
    err: Option<anyhow::Error>,
    /// Every frame, for `--mcap`, `--rosbag2` and `--rerun`.
    bag: Option<Vec<(usize, GreyImage)>>,
}

impl FrameSink {
    fn take(&mut self, step: usize, img: &GreyImage) {
        if let Some(bag) = &mut self.bag {
            bag.push((step, img.clone()));
        }
        if self.first.is_none() {
            self.first = Some((step, img.clone()));
        } else {
            self.last = Some((step, img.clone()));
        }
        let Some(dir) = &self.dir else { return };
        if self.err.is_some() {
            return;
        }
        let res = encode_png(img).map_err(anyhow::Error::from).and_then(|png| Ok(write_atomic(&dir.join(format!("step_{step:04}.png")), &png)?));
        if let Err(e) = res {
            self.err = Some(e);
        }
        if step.is_multiple_of(10) {
            if let GreyImage::U8(g) = img {
                self.thumbs.push((step, image::imageops::resize(g, 256, 205, image::imageops::FilterType::Triangle)));
            }
        }
    }

    /// Write the contact sheet into `out` (with `--frames`); the report's pictures.
    fn finish(self, out: &Path) -> anyhow::Result<Vec<Picture>> {
        if let Some(e) = self.err {
            return Err(e.context("writing frames"));
        }
        let mut pictures = Vec::new();
        if !self.thumbs.is_empty() {
            let png = synthcam::report::plot::png(&contact_sheet(&self.thumbs, 5)?)?;
            write_atomic(&out.join("contact_sheet.png"), &png)?;
            pictures.push(("contact sheet (every tenth rendered frame)".to_string(), Some("contact_sheet.png".to_string()), png));
        }
        let saved = self.dir.is_some();
        for (which, frame) in [("first", self.first), ("last", self.last)] {
            if let Some((step, img)) = frame {
                let link = saved.then(|| format!("frames/step_{step:04}.png"));
                pictures.push((format!("{which} rendered frame (step {step})"), link, encode_png(&img)?));
            }
        }
        Ok(pictures)
    }
}

/// `--mcap`, `--rosbag2`: the rendered run's frames as a ROS 2 bag.
fn write_bags(outs: &[BagOutput], spec: &RobotSpec, scenario: &SimScenario, t: &ServoTrace, bag: &[(usize, GreyImage)]) -> anyhow::Result<()> {
    let robot = spec.build(&|p| std::fs::read_to_string(p).map_err(|e| e.to_string()))?;
    for out in outs {
        let (counts, bytes) = synthcam::dataset::formats::series::write_servo_bag(out, scenario, robot.as_ref(), t, bag)
            .with_context(|| format!("writing {}", out.path().display()))?;
        super::export::print_bag(out, &counts, bytes);
    }
    Ok(())
}

/// A scenario, its robot, and where the hand-eye views are drawn (default: the start).
type Loaded = (SimScenario, RobotSpec, Option<Vec<f64>>);

/// The scenario of `--scenario`: an open scenario file (any camera, target, robot) or the course's
/// servo format (`assets/scenarios/servo_course.toml`, the default), with its robot.
fn load_scenario(args: &ServoArgs) -> anyhow::Result<Loaded> {
    match super::scenario_file::read::<ServoScenario>(args.scenario.as_deref(), "the course's servo format")? {
        ScenarioFile::Open(spec) => {
            let where_ = args.scenario.as_deref().map_or_else(String::new, |p| p.display().to_string());
            let meshes = synthcam::dataset::MeshLibrary::beside(args.scenario.as_deref().unwrap_or(std::path::Path::new(".")));
            Ok((spec.to_scenario_with(&|p: &str| meshes.load(p)).with_context(|| format!("in scenario {where_}"))?, spec.robot, None))
        }
        ScenarioFile::Course(s) => Ok((s.to_sim_scenario(args.seed).context("scenario")?, RobotSpec::Named("irb1200".into()), Some(s.handeye.q0_rad.to_vec()))),
    }
}

/// Run `servo`.
pub fn run(args: &ServoArgs) -> anyhow::Result<()> {
    let bags = super::export::bag_outputs(args.mcap.as_deref(), args.rosbag2.as_deref());
    anyhow::ensure!(!args.ideal || (bags.is_empty() && args.rerun.is_none()), "--mcap / --rosbag2 / --rerun write rendered frames: drop --ideal");
    super::rerun_out::check_available(args.rerun.as_deref())?;
    let (scenario, spec, handeye_around) = load_scenario(args)?;
    let size = scenario.camera.size;
    let run = |renderer: Option<&synthcam::render::Renderer>, observation, sink: &mut dyn FnMut(usize, &synthcam::render::GreyImage)| {
        let robot = spec.build(&|p| std::fs::read_to_string(p).map_err(|e| e.to_string()))?;
        anyhow::Ok(run_servo_on(renderer, scenario.clone(), robot, handeye_around.as_deref(), &options(args, observation), sink)?)
    };
    let law_name = if args.law == LawArg::Pbvs { "pbvs" } else { "ibvs" };
    let out = args.out.clone().unwrap_or_else(|| PathBuf::from(format!("out/servo-{law_name}")));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let mut traces: Vec<(&str, ServoTrace)> = Vec::new();
    let mut frames = Vec::new();
    if !args.ideal {
        let renderer = super::open_renderer("auto")?;
        let mut sink =
            FrameSink { dir: args.frames.then(|| out.join("frames")), bag: (!bags.is_empty() || args.rerun.is_some()).then(Vec::new), ..FrameSink::default() };
        if let Some(dir) = &sink.dir {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        eprintln!("{law_name}: rendered + detected (hand-eye from {}) ...", if args.true_handeye { "the truth" } else { "5 rendered views" });
        let bar = super::progress::bar(options(args, ObservationKind::Rendered).max_steps as u64, law_name, "steps");
        let t = run(Some(&renderer), ObservationKind::Rendered, &mut |step, img| {
            bar.set_position(step as u64 + 1);
            sink.take(step, img);
        })
        .context("servo run")?;
        bar.finish_and_clear();
        if let Some(bag) = &sink.bag {
            write_bags(&bags, &spec, &scenario, &t, bag)?;
            #[cfg(feature = "rerun")]
            if let Some(path) = &args.rerun {
                let robot = spec.build(&|p| std::fs::read_to_string(p).map_err(|e| e.to_string()))?;
                super::rerun_out::servo(path, &scenario, robot.as_ref(), &t, bag)?;
            }
        }
        frames = sink.finish(&out)?;
        print_run("rendered + detected", &t);
        write_trace(&out, "trace", &t)?;
        traces.push(("rendered + detected", t));
    }
    if args.ideal || !args.no_compare {
        let t = run(None, ObservationKind::Ideal, &mut |_, _| {}).context("servo run (ideal)")?;
        print_run("ideal + 0.1 px", &t);
        write_trace(&out, if args.ideal { "trace" } else { "trace_ideal" }, &t)?;
        traces.push(("ideal + 0.1 px", t));
    }
    write_report(&out, law_name, &traces, (size.width, size.height), frames)?;
    println!("traces, plots, summary.md and report.html written to {}", out.display());
    let primary = &traces[0].1;
    let stop_requested = !(args.course || args.no_stop);
    anyhow::ensure!(primary.status.is_success(stop_requested), "{} run ended: {}", law_name.to_uppercase(), primary.status.describe());
    Ok(())
}
