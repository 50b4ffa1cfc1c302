//! `synthcam handeye [--scenario F] [--views M] [--seed S] [--ideal] [--json OUT]`: the hand-eye
//! experiment (default: the course's variant A; or any open scenario) on rendered and detected
//! pixels, or on ideal projections + noise.

use std::path::PathBuf;

use anyhow::Context;
use synthcam::course::handeye_run::{run_handeye, run_handeye_on};
use synthcam::dataset::write_atomic;
use synthcam::robot::Cell;
use synthcam::sim::sensor::ObservationKind;

use super::scenario_file::ScenarioFile;

/// Arguments of `handeye`.
#[derive(Debug, clap::Args)]
pub struct HandEyeArgs {
    /// Scenario file (TOML): the course's cell format (default: variant A,
    /// assets/scenarios/course.toml) or an open scenario (any camera, target, robot; views around
    /// its start joints).
    #[arg(long)]
    pub scenario: Option<PathBuf>,
    /// Open scenarios: joints drawn within this of the start, radians.
    #[arg(long, default_value_t = 0.25)]
    pub spread: f64,
    /// Views.
    #[arg(long, default_value_t = 5)]
    pub views: usize,
    /// Seed of the robot configurations and the noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Ideal projections + 0.1 px noise (the course's method) instead of rendered + detected.
    #[arg(long)]
    pub ideal: bool,
    /// Write the estimates and errors as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Run `handeye`.
pub fn run(args: &HandEyeArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.views >= 3, "--views must be at least 3 (the AX = XB solver needs 3 views), got {}", args.views);
    let obs = if args.ideal { ObservationKind::Ideal } else { ObservationKind::Rendered };
    let renderer = if args.ideal { None } else { Some(super::open_renderer("auto")?) };
    let (r, x, wb) = match super::scenario_file::read::<Cell>(args.scenario.as_deref(), "a course cell")? {
        ScenarioFile::Course(cell) => {
            let (x, wb) = cell.truth();
            (run_handeye(renderer.as_ref(), obs, &cell, args.views, args.seed).context("hand-eye experiment")?, x, wb)
        }
        ScenarioFile::Open(spec) => {
            let meshes = synthcam::dataset::MeshLibrary::beside(args.scenario.as_deref().unwrap_or(std::path::Path::new(".")));
            let sc = spec.to_scenario_with(&|p: &str| meshes.load(p)).context("scenario")?;
            let (x, wb) = (sc.tool_from_cam, sc.world_from_target.inverse() * sc.world_from_base);
            let robot = spec.robot.build(&|p| std::fs::read_to_string(p).map_err(|e| e.to_string()))?;
            (run_handeye_on(renderer.as_ref(), obs, sc, robot, args.views, args.spread, args.seed).context("hand-eye experiment")?, x, wb)
        }
    };
    let show = |name: &str, est: &nalgebra::Isometry3<f64>, truth: &nalgebra::Isometry3<f64>| {
        let t = est.translation.vector;
        let e = 1e3 * (t - truth.translation.vector).norm();
        let a = (est.rotation * truth.rotation.inverse()).angle().to_degrees();
        println!("{name:<34} t = ({:+.5}, {:+.5}, {:+.5}) m   error {e:.3} mm, {a:.4} deg", t.x, t.y, t.z);
    };
    println!("{} views ({} configurations drawn), {}", args.views, r.drawn, if args.ideal { "ideal projections + 0.1 px" } else { "rendered + detected" });
    println!("PnP camera position errors, mm: {:?}", r.pnp_mm.iter().map(|v| (v * 1e3).round() / 1e3).collect::<Vec<_>>());
    show("tool_from_cam (course linear)", &r.linear.tool_from_cam, &x);
    show("world_from_base (course linear)", &r.linear.world_from_base, &wb);
    show("tool_from_cam (Park-Martin)", &r.park_martin.tool_from_cam, &x);
    show("world_from_base (Park-Martin)", &r.park_martin.world_from_base, &wb);
    show("tool_from_cam (refined)", &r.refined.tool_from_cam, &x);
    show("world_from_base (refined)", &r.refined.world_from_base, &wb);
    println!("refined: reprojection RMS per view, px: {:?}", r.refined.view_rms_px.iter().map(|v| (v * 1e4).round() / 1e4).collect::<Vec<_>>());
    if let Some(p) = &args.json {
        let v = serde_json::json!({
            "views": args.views, "seed": args.seed, "mode": if args.ideal { "ideal" } else { "rendered" },
            "pnp_position_error_mm": r.pnp_mm,
            "errors": {
                "linear_tool_from_cam": {"mm": r.errors[0].mm, "deg": r.errors[0].deg},
                "linear_world_from_base": {"mm": r.errors[1].mm, "deg": r.errors[1].deg},
                "park_martin_tool_from_cam": {"mm": r.errors[2].mm, "deg": r.errors[2].deg},
                "park_martin_world_from_base": {"mm": r.errors[3].mm, "deg": r.errors[3].deg},
                "refined_tool_from_cam": {"mm": r.errors[4].mm, "deg": r.errors[4].deg},
                "refined_world_from_base": {"mm": r.errors[5].mm, "deg": r.errors[5].deg},
            },
            "residuals_m": {"linear": r.linear.residual_m, "park_martin": r.park_martin.residual_m},
            "refined_view_rms_px": r.refined.view_rms_px,
        });
        write_atomic(p, &serde_json::to_vec_pretty(&v)?)?;
    }
    Ok(())
}
