//! End-to-end tests, built as one binary: `cargo test --release --test e2e`.

#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod architecture;
mod area_light;
mod background;
mod bad_input;
mod batch;
mod bench_report;
mod calibrate_cli;
mod calibrate_outliers;
mod calibration;
mod camera_effects;
mod charuco;
mod chessboard_accuracy;
mod common;
mod coverage_exact;
mod dataset;
mod detect_cli;
mod determinism;
mod dot_accuracy;
mod dot_fidelity;
mod dot_grid;
mod fidelity;
mod formats;
mod golden;
mod handeye;
mod html_report;
mod lens_models;
mod lighting;
mod lit_objects;
mod objects;
mod open_scenario;
mod options_proptest;
mod progress;
mod real_sets;
mod rig_calibration;
mod robot_motion;
mod robustness;
mod robustness_experiment;
mod sensor_effects;
mod servo;
mod shadow;
mod sim_bag;
mod tracking;
mod truth;
mod warped_board;
