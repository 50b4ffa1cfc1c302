//! Option structs of `sim`, `dataset` and `report` with arbitrary values (zeros, negatives, NaN,
//! huge): every call returns a value or a typed error, never a panic.

use image::GrayImage;
use proptest::prelude::*;
use synthcam::course::servo_run::{run_servo, HandEyeSource, ServoOptions, ServoScenario};
use synthcam::course::sweep::run_sweep;
use synthcam::course::sweep::SweepMode;
use synthcam::dataset::generate::Shard;
use synthcam::report::servo::{budget_table, contact_sheet, csv, error_png};
use synthcam::report::sweep::plot_png;
use synthcam::sim::controller::Law;
use synthcam::sim::open_run::{run_open, OpenRunOptions};
use synthcam::sim::sensor::IdealSensor;
use synthcam::sim::{ScenarioSpec, Sim};

fn odd_f64() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), Just(-1.0), Just(f64::NAN), Just(f64::INFINITY), Just(1e300), -10.0..10.0f64]
}

fn ideal_sim() -> Sim<'static> {
    let spec = ScenarioSpec::parse(synthcam::sim::UR5E_CHESSBOARD).expect("scenario");
    let robot = spec.robot.build(&|_| Err("no files".into())).expect("robot");
    Sim::new(spec.to_scenario().expect("valid"), robot, Box::new(IdealSensor::new(0.1, 0).expect("sensor"))).expect("sim")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn servo_options_never_panic(stall in 0usize..4, steps in 0usize..4, noise in odd_f64(), min_dots in 0usize..200, singular in odd_f64(), ibvs in any::<bool>()) {
        let mut o = ServoOptions::new(if ibvs { Law::Ibvs } else { Law::Pbvs });
        o.observation = synthcam::sim::sensor::ObservationKind::Ideal;
        o.handeye = HandEyeSource::Truth;
        (o.stall_window, o.max_steps, o.ideal_noise_px, o.min_dots, o.singular_stop) = (stall, steps, noise, min_dots, singular);
        if let Ok(t) = run_servo(None, &ServoScenario::default(), &o, &mut |_, _| {}) {
            let _ = (csv(&t), budget_table(&[("run", &t)]).markdown(), error_png(&[("run", &t)]));
        }
    }

    #[test]
    fn sim_commands_and_open_runs_never_panic(qdot in prop::collection::vec(odd_f64(), 0..8), dt in odd_f64(), steps in 0usize..3, views in 0usize..4, spread in odd_f64()) {
        let mut sim = ideal_sim();
        let _ = sim.command_joint_velocities(&qdot, dt);
        let _ = sim.set_joints(&qdot);
        let _ = run_open(&mut sim, &OpenRunOptions { max_steps: steps, dt_s: dt.abs(), handeye_views: views, spread_rad: spread, ..Default::default() });
    }

    #[test]
    fn report_and_dataset_options_never_panic(ms in prop::collection::vec(0usize..40, 0..4), ns in prop::collection::vec(0usize..6, 0..3), cols in 0u32..4, sizes in prop::collection::vec((1u32..6, 1u32..6), 0..4), index in 0u64..4, count in 0u64..4) {
        let _ = plot_png(&[], &ms, &ns);
        if ms.iter().all(|m| *m <= 12) {
            let _ = run_sweep(SweepMode::Ideal, &ms, &ns, 1, None);
        }
        let frames: Vec<(usize, GrayImage)> = sizes.iter().enumerate().map(|(k, (w, h))| (k, GrayImage::new(*w, *h))).collect();
        let _ = contact_sheet(&frames, cols);
        let _ = Shard { index, count }.contains(7);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Camera effects with arbitrary values: parse-free construction, validation, rendering of the
    /// valid ones (a 64 x 48 board), truth and JPEG encoding return values or typed errors.
    #[test]
    fn camera_effect_options_never_panic(fields in prop::collection::vec((0usize..22, odd_f64()), 0..6), bits in 0u8..20, samples in 0u32..300, rolling in any::<bool>()) {
        let mut scene = synthcam::scene::file::parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
        scene.camera.size = synthcam::camera::ImageSize { width: 64, height: 48 };
        scene.camera.intrinsics.fx = 75.0;
        scene.camera.intrinsics.fy = 75.0;
        scene.camera.intrinsics.cx = 31.5;
        scene.camera.intrinsics.cy = 23.5;
        let fx = &mut scene.render.effects;
        fx.sensor = Some(synthcam::camera::sensor::SensorModel { bit_depth: bits, ..Default::default() });
        fx.optics.thin_lens = Some(synthcam::camera::optics::ThinLens { f_number: 2.0, focal_length_m: 0.016, focus_distance_m: 0.5, aperture_samples: samples });
        fx.motion.line_delay_s = if rolling { 1e-4 } else { 0.0 };
        for (i, v) in &fields {
            let _ = synthcam::scene::effect_fields::set_field(&mut scene.render, synthcam::scene::effect_fields::FIELDS[*i], *v);
        }
        if scene.validate().is_ok() {
            let img = crate::common::renderer().render(&scene);
            let _ = synthcam::scene::truth::truth_labels(&scene);
            if let Ok(img) = img {
                let _ = synthcam::render::formation::jpeg_bytes(&img, 50);
            }
        }
    }
}
