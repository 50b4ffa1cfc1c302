#![allow(missing_docs)]
//! Criterion benchmarks of the pipeline stages on the embedded scenes (1280 x 1024):
//! detection (chessboard corners, S-path dots), calibration (10 views), PnP, and one servo step
//! (the IBVS and PBVS laws alone, and a whole closed-loop IBVS step: render + detect + law).
//! `cargo bench --bench pipeline`.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use synthcam::calib::{calibrate, CalibParams, View};
use synthcam::course::servo_run::{run_servo, HandEyeSource, ServoOptions, ServoScenario};
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::render::{GpuContext, Renderer};
use synthcam::robot::variant_a;
use synthcam::robot::{base_from_tool, Joints};
use synthcam::scene::file::parse_scene;
use synthcam::scene::Scene;
use synthcam::servo::{ibvs_step, image_jacobian, pbvs_error, pbvs_step, IbvsParams, PbvsParams};
use synthcam::sim::controller::Law;
use synthcam::sim::observe::{pose_from_dots, render_and_detect};
use synthcam::sim::sensor::ObservationKind;

fn renderer() -> Renderer {
    match GpuContext::new_headless() {
        Ok(ctx) => Renderer::new(ctx),
        Err(e) => panic!("no GPU adapter: {e}"),
    }
}

fn scene(text: &str) -> Scene {
    match parse_scene(text) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

fn grey(r: &Renderer, s: &Scene) -> ImageF32 {
    let img = r.render(s).unwrap_or_else(|e| panic!("{e}"));
    ImageF32::from_u8(s.camera.size.width as usize, s.camera.size.height as usize, &img.to_u8()).unwrap_or_else(|e| panic!("{e}"))
}

fn bench_detect(c: &mut Criterion) {
    let r = renderer();
    let board = scene(include_str!("../assets/scenes/chessboard_k1.toml"));
    let s_path = scene(include_str!("../assets/scenes/course_s_path.toml"));
    let (gb, gs) = (grey(&r, &board), grey(&r, &s_path));
    let mut g = c.benchmark_group("detect 1280x1024");
    g.sample_size(20);
    g.bench_function("chessboard 11x8 corners", |b| b.iter(|| detect(&gb, &TargetSpec::Chessboard { cols: 11, rows: 8 }).map(|d| d.points_px.len())));
    g.bench_function("S-path 101 dots", |b| b.iter(|| detect(&gs, &TargetSpec::SPath { points: 101 }).map(|d| d.points_px.len())));
    // The dots alone: a servo loop's tracked frames carry their labels and spend their detection here.
    g.bench_function("S-path dots found (no labelling)", |b| {
        b.iter(|| synthcam::detect::dots::find_dots(&gs, &synthcam::detect::dots::DotParams::default()).map(|d| d.len()))
    });
    g.finish();
}

/// 10 views of an 8 x 6 inner-corner board projected by the chessboard scene's camera.
fn calib_views() -> (Scene, Vec<View>) {
    let base = scene(include_str!("../assets/scenes/chessboard_k1.toml"));
    let square = 0.05;
    let pts: Vec<Point3<f64>> = (0..48).map(|k| Point3::new(square * f64::from(k % 8 + 1), square * f64::from(k / 8 + 1), 0.0)).collect();
    let views = (0..10u32)
        .map(|i| {
            let a = f64::from(i) * 0.9;
            let axis = nalgebra::Unit::new_normalize(Vector3::new(a.cos(), a.sin(), 0.0));
            let rot = UnitQuaternion::from_axis_angle(&axis, (15.0 + 2.0 * f64::from(i)).to_radians());
            let centre = Vector3::new(4.5 * square, 3.5 * square, 0.0);
            let t = Vector3::new(0.06 * a.sin(), 0.05 * a.cos(), 0.9) - rot * centre;
            let pose = Isometry3::from_parts(Translation3::from(t), rot);
            pts.iter().map(|p| (*p, base.camera.project_unchecked(&(pose * p)))).collect::<View>()
        })
        .collect();
    (base, views)
}

fn bench_calibrate(c: &mut Criterion) {
    let (base, views) = calib_views();
    let mut g = c.benchmark_group("calibrate");
    g.sample_size(20);
    g.bench_function("10 views x 48 corners, k1 k2 p1 p2 k3", |b| b.iter(|| calibrate(&views, base.camera.size, &CalibParams::default()).map(|r| r.rms_px)));
    g.finish();
}

fn bench_servo(c: &mut Criterion) {
    let r = renderer();
    let s_path = scene(include_str!("../assets/scenes/course_s_path.toml"));
    let seen = render_and_detect(&r, &s_path).unwrap_or_else(|e| panic!("{e}"));
    let dots = seen.dots.unwrap_or_else(|| panic!("S-path not found"));
    let (x, wb) = variant_a();
    let q = Joints::from_row_slice(&[0.1, 1.6, 3.5, 3.0, 2.0, 0.0]);
    let pts = synthcam::target::spherical_s().points_m;
    let cam = s_path.camera;
    let cw = (wb * base_from_tool(&q) * x).inverse();
    let measured: Vec<Point2<f64>> = pts.iter().map(|p| cam.project_unchecked(&(cw * p))).collect();
    let desired: Vec<Point2<f64>> = measured.iter().map(|p| p + Vector3::new(3.0, -2.0, 0.0).xy()).collect();
    let mut g = c.benchmark_group("servo step");
    g.sample_size(20);
    g.bench_function("IBVS law (image Jacobian 202x6 + damped step)", |b| {
        b.iter(|| {
            let l = image_jacobian(&cam, &q, &wb, &x, &pts);
            ibvs_step(&q, &l, &measured, &desired, &IbvsParams::default()).map(|s| s.1)
        })
    });
    g.bench_function("PBVS law (PnP on 101 dots + step)", |b| {
        b.iter(|| {
            let est = pose_from_dots(&s_path, &dots, 0).unwrap_or_else(|e| panic!("{e}")).0;
            let tool = wb.inverse() * est.cam_from_target.inverse() * x.inverse();
            pbvs_step(&q, &pbvs_error(&tool, &base_from_tool(&q)), &PbvsParams::default()).map(|n| n[0])
        })
    });
    g.bench_function("PnP with bead-centroid correction (1 round)", |b| b.iter(|| pose_from_dots(&s_path, &dots, 1).map(|r| r.0.rms_px)));
    g.bench_function("closed-loop IBVS step (render + detect + law)", |b| {
        let mut o = ServoOptions::new(Law::Ibvs);
        o.max_steps = 1;
        o.stop = None;
        o.handeye = HandEyeSource::Truth;
        o.observation = ObservationKind::Rendered;
        // One run = desired-feature render + 2 loop steps; reported per run.
        b.iter(|| run_servo(Some(&r), &ServoScenario::default(), &o, &mut |_, _| {}).map(|t| t.steps.len()))
    });
    g.finish();
}

criterion_group!(benches, bench_detect, bench_calibrate, bench_servo);
criterion_main!(benches);
