//! `synthcam demo`: renders the embedded default scenes, detects their targets on the rendered
//! pixels and reports detection against the truth labels; then calibrates the course camera from
//! rendered chessboard views, runs the course's hand-eye experiment on rendered S-path dots, and
//! closes PBVS and IBVS loops through the renderer and the detector, reporting every estimate
//! against the truth.

use std::path::Path;

use anyhow::Context;
use nalgebra::Point2;
use synthcam::course::servo_run::{run_servo, ServoOptions, ServoScenario};
use synthcam::dataset::{encode_png, write_image_and_truth};
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::render::Renderer;
use synthcam::report::doc::{Document, Table};
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;
use synthcam::sim::controller::Law;
use synthcam::sim::sensor::ObservationKind;
use synthcam::target::Target;

/// Run the demo into `out`.
pub fn run(out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let renderer = super::open_renderer("auto")?;
    let mut report = Document::new("synthcam demo");
    let bar = super::progress::bar(4, "demo", "stages");
    bar.set_message("render + detect");
    scenes(&renderer, out, &mut report)?;
    bar.inc(1);
    bar.set_message("calibration");
    calibration(&renderer, &mut report)?;
    bar.inc(1);
    bar.set_message("hand-eye");
    hand_eye(&renderer, &mut report)?;
    bar.inc(1);
    bar.set_message("PBVS + IBVS in the loop");
    servo(&renderer, out, &mut report)?;
    bar.finish_and_clear();
    super::write_document(out, Some("report.md"), &report)?;
    println!("demo images, truth JSON, report.md and report.html written to {}", out.display());
    Ok(())
}

/// The default scenes rendered, written with their truth and detected: the report's first
/// section (a table, then the frames).
fn scenes(renderer: &Renderer, out: &Path, report: &mut Document) -> anyhow::Result<()> {
    let mut table = Table::new(["scene", "target", "render ms", "found", "points", "error vs truth RMS px", "max px"]);
    let mut frames = Vec::new();
    for (name, text) in super::DEFAULT_SCENES {
        let mut scene = parse_scene(text).with_context(|| format!("embedded scene {name}"))?;
        scene.render.noise_sigma = 1.0;
        // Warm the pipeline up (lavapipe compiles the shader on first use), then time one frame.
        renderer.render(&scene).with_context(|| format!("rendering {name}"))?;
        let t0 = std::time::Instant::now();
        let img = renderer.render(&scene).with_context(|| format!("rendering {name}"))?;
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let truth = truth_labels(&scene);
        let path = out.join(format!("{name}.png"));
        write_image_and_truth(&path, &img, &truth)?;
        let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
        let grey = ImageF32::from_u8(w, h, &img.to_u8())?;
        let spec = TargetSpec::for_target(&scene.target);
        let det = detect(&grey, &spec)?;
        // Dots are compared with the blob centroid, corners with the projected corner; both
        // order-agnostically (nearest truth feature).
        let truth_px: Vec<Point2<f64>> = truth.features.iter().filter(|f| f.visible).map(|f| Point2::from(f.centroid_px.unwrap_or(f.pixel_px))).collect();
        let errs: Vec<f64> = det.points_px.iter().map(|p| truth_px.iter().map(|t| (p - t).norm()).fold(f64::INFINITY, f64::min)).collect();
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
        let max = errs.iter().cloned().fold(0.0, f64::max);
        println!(
            "{name}: {}x{} {} rendered in {ms:.0} ms -> {}; detected {} of {} points, error vs truth RMS {rms:.4} px (max {max:.4})",
            w,
            h,
            scene.target.kind_name(),
            path.display(),
            det.points_px.len(),
            truth_px.len()
        );
        table.push([
            name.to_string(),
            scene.target.kind_name().to_string(),
            format!("{ms:.0}"),
            det.found.to_string(),
            format!("{}/{}", det.points_px.len(), truth_px.len()),
            format!("{rms:.4}"),
            format!("{max:.4}"),
        ]);
        frames.push((format!("{name}: rendered frame"), format!("{name}.png"), encode_png(&img)?));
    }
    report.heading(2, "Render and detect").table(table);
    for (alt, link, png) in frames {
        report.image(alt, Some(link), png);
    }
    Ok(())
}

/// Calibration from rendered and detected views: the report's section.
fn calibration(renderer: &Renderer, report: &mut Document) -> anyhow::Result<()> {
    // Calibration: 10 rendered views of a 8 x 6 board under the chessboard scene's strong
    // distortion, detected, calibrated.
    let t0 = std::time::Instant::now();
    let base = parse_scene(super::DEFAULT_SCENES[1].1).context("embedded chessboard scene")?;
    let (views, cal) = calibration_views(renderer, &base)?;
    let k = cal.camera.intrinsics;
    let kt = base.camera.intrinsics;
    println!(
        "calibration from {views} rendered views: fx {:.3} fy {:.3} cx {:.3} cy {:.3} (truth {} {} {} {}), k1 {:.5} (truth {}), RMS {:.4} px, {:.1} s",
        k.fx,
        k.fy,
        k.cx,
        k.cy,
        kt.fx,
        kt.fy,
        kt.cx,
        kt.cy,
        cal.camera.distortion().k1,
        base.camera.distortion().k1,
        cal.rms_px,
        t0.elapsed().as_secs_f64()
    );
    let (dt, de) = (base.camera.distortion(), cal.camera.distortion());
    let mut table = Table::new(["", "fx", "fy", "cx", "cy", "k1", "k2"]);
    table.push(["truth".to_string(), kt.fx.to_string(), kt.fy.to_string(), kt.cx.to_string(), kt.cy.to_string(), dt.k1.to_string(), dt.k2.to_string()]);
    let est =
        [format!("{:.3}", k.fx), format!("{:.3}", k.fy), format!("{:.3}", k.cx), format!("{:.3}", k.cy), format!("{:.5}", de.k1), format!("{:.5}", de.k2)];
    table.push(std::iter::once("estimate".to_string()).chain(est));
    report.heading(2, format!("Calibration from {views} rendered and detected views")).table(table);
    report.paragraph(format!("RMS reprojection error {:.4} px.", cal.rms_px));
    Ok(())
}

/// The course's hand-eye experiment on rendered views: the report's section.
fn hand_eye(renderer: &Renderer, report: &mut Document) -> anyhow::Result<()> {
    // Hand-eye: the course's variant A, 5 views, rendered and detected S-path dots.
    let t0 = std::time::Instant::now();
    let he = synthcam::course::handeye_run::run_handeye(Some(renderer), synthcam::sim::sensor::ObservationKind::Rendered, &Default::default(), 5, 0)
        .context("hand-eye experiment")?;
    let names = [
        "tool_from_cam (course linear)",
        "world_from_base (course linear)",
        "tool_from_cam (Park-Martin)",
        "world_from_base (Park-Martin)",
        "tool_from_cam (refined)",
        "world_from_base (refined)",
    ];
    let mut table = Table::new(["estimate", "error mm", "error deg"]);
    for (n, e) in names.iter().zip(he.errors) {
        table.push([n.to_string(), format!("{:.3}", e.mm), format!("{:.4}", e.deg)]);
    }
    report.heading(2, "Hand-eye (course variant A, 5 rendered views)").table(table);
    println!(
        "hand-eye from 5 rendered views: refined tool_from_cam error {:.3} mm / {:.4} deg, world_from_base {:.3} mm, {:.1} s",
        he.errors[4].mm,
        he.errors[4].deg,
        he.errors[5].mm,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// PBVS and IBVS from the course's start, rendered and ideal: traces, plots, the report's sections.
fn servo(renderer: &Renderer, out: &Path, report: &mut Document) -> anyhow::Result<()> {
    // Visual servoing: PBVS and IBVS from the course's start, rendered + detected at every step,
    // next to ideal projections + 0.1 px.
    for (law, name) in [(Law::Pbvs, "pbvs"), (Law::Ibvs, "ibvs")] {
        let t0 = std::time::Instant::now();
        println!("{}: closed loop from the course's start (render + detect every step) ...", name.to_uppercase());
        let dir = out.join(name);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut traces = Vec::new();
        for (obs, label) in [(ObservationKind::Rendered, "rendered + detected"), (ObservationKind::Ideal, "ideal + 0.1 px")] {
            let options = ServoOptions { observation: obs, ..ServoOptions::new(law) };
            let r = (obs == ObservationKind::Rendered).then_some(renderer);
            let t = run_servo(r, &ServoScenario::default(), &options, &mut |_, _| {}).with_context(|| format!("{name} run"))?;
            super::servo::write_trace(&dir, if obs == ObservationKind::Rendered { "trace" } else { "trace_ideal" }, &t)?;
            traces.push((label, t));
        }
        let section = super::servo::write_report(&dir, name, &traces, (1280, 1024), Vec::new())?;
        if let Some(s) = traces[0].1.last() {
            println!(
                "{}: {} after {} updates, camera {:.3} mm / {:.4} deg from the desired pose, pixel error RMS {:.3} px, {:.1} s",
                name.to_uppercase(),
                traces[0].1.status.describe(),
                traces[0].1.updates,
                s.pose_error_mm,
                s.pose_error_deg,
                s.pixel_rms_px,
                t0.elapsed().as_secs_f64()
            );
        }
        report.heading(2, format!("{} from the course's start (course-scenario 3.{})", name.to_uppercase(), if law == Law::Pbvs { 7 } else { 8 }));
        report.paragraph(
            "Desired camera pose T_0C* = [(-e_y, e_z, -e_x), (1.8, 0, 0.55)]; truth = where the camera really is (forward kinematics with the true hand-eye).",
        );
        report.append(section, &format!("{name}/"));
    }
    Ok(())
}

/// Render 10 views of an 8 x 6 inner-corner board with `base`'s camera, detect and calibrate.
fn calibration_views(renderer: &synthcam::render::Renderer, base: &synthcam::scene::Scene) -> anyhow::Result<(usize, synthcam::calib::CalibResult)> {
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
    use synthcam::detect::{find_chessboard, ChessboardParams};
    let square = 0.05;
    let board = synthcam::target::Chessboard { squares: [9, 7], square_m: square, margin_m: 0.5 * square, ..Default::default() };
    let mut views = Vec::new();
    for i in 0..14u32 {
        if views.len() == 10 {
            break;
        }
        let a = f64::from(i) * 0.9;
        let axis = nalgebra::Unit::new_normalize(Vector3::new(a.cos(), a.sin(), 0.0));
        let rot = UnitQuaternion::from_axis_angle(&axis, (15.0 + 2.0 * f64::from(i)).to_radians());
        let centre = Vector3::new(4.5 * square, 3.5 * square, 0.0);
        let offset = Vector3::new(0.06 * a.sin(), 0.05 * a.cos(), 0.9 + 0.03 * f64::from(i % 4));
        let scene = synthcam::scene::Scene {
            target: Target::Chessboard(board),
            cam_from_target: Isometry3::from_parts(Translation3::from(offset - rot * centre), rot),
            render: synthcam::scene::RenderSettings { noise_sigma: 1.0, seed: u64::from(i), ..Default::default() },
            ..base.clone()
        };
        let img = renderer.render(&scene)?;
        let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
        let Some(found) = find_chessboard(&ImageF32::from_u8(w, h, &img.to_u8())?, &ChessboardParams::new(8, 6))? else { continue };
        let pts: Vec<Point3<f64>> = (0..48).map(|k| Point3::new(square * f64::from(k % 8 + 1), square * f64::from(k / 8 + 1), 0.0)).collect();
        views.push(pts.into_iter().zip(found.points_px).collect::<synthcam::calib::View>());
    }
    let cal = synthcam::calib::calibrate(&views, base.camera.size, &synthcam::calib::CalibParams::default())?;
    Ok((views.len(), cal))
}
