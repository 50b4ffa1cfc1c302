//! Servo traces for people and tools: CSV, PNG plots (error per step, singular values, feature
//! tracks, camera path), the side-by-side error budget (ideal vs rendered) and a contact sheet of
//! frames.

use image::{GrayImage, Rgb, RgbImage};
use imageproc::drawing::{draw_cross_mut, draw_hollow_circle_mut};

use super::plot::{canvas, png, text, Panel, PALETTE};
use super::ReportError;
use crate::sim::servo_run::{ServoTrace, Source, StepRecord};

/// One CSV row per step (features are in the JSON trace).
pub fn csv(trace: &ServoTrace) -> String {
    let mut out = String::from("step,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,cam_x_m,cam_y_m,cam_z_m,pose_error_mm,pose_error_deg,est_error_mm,est_error_deg,pixel_rms_px,pixel_max_px,sigma_min_robot,sigma_min_image,dots,within_limits,source,gain,render_ms,detect_ms,law_ms\n");
    for s in &trace.steps {
        let q: Vec<String> = s.q_rad.iter().map(|v| format!("{v:.9}")).collect();
        let c: Vec<String> = s.cam_position_m.iter().map(|v| format!("{v:.6}")).collect();
        let source = serde_json::to_value(s.source).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default();
        out += &format!(
            "{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6e},{:.6e},{},{},{source},{:.6},{:.3},{:.3},{:.3}\n",
            s.step,
            q.join(","),
            c.join(","),
            s.pose_error_mm,
            s.pose_error_deg,
            s.est_error_mm,
            s.est_error_deg,
            s.pixel_rms_px,
            s.pixel_max_px,
            s.sigma_min_robot,
            s.sigma_min_image,
            s.dots,
            u8::from(s.within_limits),
            s.gain,
            s.render_ms,
            s.detect_ms,
            s.law_ms
        );
    }
    out
}

/// Ticks at powers of ten over `[lo, hi]` (log10 units).
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    (lo.floor() as i32..=hi.ceil() as i32).map(|e| (f64::from(e), if e >= 0 { format!("{}", 10f64.powi(e)) } else { format!("1e{e}") })).collect()
}

fn step_ticks(n: usize) -> Vec<(f64, String)> {
    let every = (n / 5).max(1);
    (0..=n).step_by(every).map(|s| (s as f64, s.to_string())).collect()
}

/// A named quantity of a step.
type Series<'a> = (&'a str, fn(&StepRecord) -> f64);

/// One panel of log10 series per step for each trace, side by side on the same axes (so no run's
/// curves can hide another's), one colour per series with its legend inside the panel.
fn log_series_png(title: &str, ylabel: &str, traces: &[(&str, &ServoTrace)], series: &[Series<'_>]) -> Result<Vec<u8>, ReportError> {
    let panels = traces.len().max(1) as u32;
    let mut img = canvas(90 + 540 * panels, 540);
    let n = traces.iter().map(|(_, t)| t.steps.len()).max().unwrap_or(1).max(2) - 1;
    let all: Vec<f64> = traces
        .iter()
        .flat_map(|(_, t)| t.steps.iter().flat_map(|s| series.iter().map(move |(_, f)| f(s))))
        .filter(|v| *v > 0.0 && v.is_finite())
        .map(f64::log10)
        .collect();
    let lo = all.iter().copied().fold(f64::INFINITY, f64::min).min(0.0).floor().max(-6.0);
    let hi = all.iter().copied().fold(f64::NEG_INFINITY, f64::max).max(lo + 1.0).ceil();
    text(&mut img, 20, 8, title, image::Rgb([0, 0, 0]), 2);
    for (ti, (tname, t)) in traces.iter().enumerate() {
        let left = 90 + 540 * ti as i32;
        let panel = Panel { rect: (left, 80, 460, 400), x: (0.0, n as f64), y: (lo, hi) };
        panel.axes(&mut img, tname, "step", ylabel, &step_ticks(n), &log_ticks(lo, hi));
        for (si, (sname, f)) in series.iter().enumerate() {
            let pts: Vec<(f64, f64)> = t.steps.iter().map(|s| (s.step as f64, f(s).max(10f64.powf(lo)).log10())).collect();
            let colour = PALETTE[si % PALETTE.len()];
            panel.line(&mut img, &pts, colour);
            text(&mut img, left + 300, 90 + 14 * si as i32, sname, colour, 1);
        }
    }
    png(&img)
}

/// Error per step: the true pose error (mm, degrees) and the pixel error, for each trace.
///
/// # Errors
/// PNG encoding.
pub fn error_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    log_series_png(
        "error per step",
        "log10",
        traces,
        &[("pose mm", |s| s.pose_error_mm), ("pose deg", |s| s.pose_error_deg), ("pixel RMS px", |s| s.pixel_rms_px)],
    )
}

/// Smallest singular values of the robot and image Jacobians per step.
///
/// # Errors
/// PNG encoding.
pub fn singular_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    log_series_png("smallest singular values", "log10", traces, &[("robot J", |s| s.sigma_min_robot), ("image J", |s| s.sigma_min_image)])
}

/// Feature tracks in the image: every dot's measured path over the steps (blue to red), the
/// desired features as green circles.
///
/// # Errors
/// PNG encoding.
pub fn tracks_png(trace: &ServoTrace, width: u32, height: u32) -> Result<Vec<u8>, ReportError> {
    let scale = 0.6;
    let (w, h) = ((f64::from(width) * scale) as u32, (f64::from(height) * scale) as u32);
    let mut img = canvas(w + 40, h + 70);
    let panel = Panel { rect: (20, 50, w as i32, h as i32), x: (-0.5, f64::from(width) - 0.5), y: (-(f64::from(height) - 0.5), 0.5) };
    panel.axes(&mut img, "feature tracks (green: desired)", "", "", &[], &[]);
    let n = trace.steps.len().max(2) - 1;
    let ids = trace.desired_px.len();
    for id in 0..ids {
        let pts: Vec<(f64, f64)> = trace.steps.iter().filter_map(|s| s.features_px.iter().find(|f| f[0] as usize == id).map(|f| (f[1], -f[2]))).collect();
        for (k, w2) in pts.windows(2).enumerate() {
            let t = k as f64 / n as f64;
            let colour = Rgb([(255.0 * t) as u8, 40, (255.0 * (1.0 - t)) as u8]);
            panel.line(&mut img, w2, colour);
        }
    }
    for d in trace.desired_px.iter().flatten() {
        let (u, v) = panel.px(d[0], -d[1]);
        draw_hollow_circle_mut(&mut img, (u as i32, v as i32), 4, Rgb([0, 160, 0]));
    }
    png(&img)
}

/// The camera path seen from above (x, y) and from the side (x, z), with the goal.
///
/// # Errors
/// PNG encoding.
pub fn path_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    let mut img = canvas(1100, 520);
    let pts: Vec<[f64; 3]> = traces.iter().flat_map(|(_, t)| t.steps.iter().map(|s| s.cam_position_m).chain(std::iter::once(t.goal_position_m))).collect();
    let range = |i: usize| {
        let lo = pts.iter().map(|p| p[i]).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(|p| p[i]).fold(f64::NEG_INFINITY, f64::max);
        let pad = 0.1 * (hi - lo).max(0.05);
        (lo - pad, hi + pad)
    };
    let ticks = |(lo, hi): (f64, f64)| -> Vec<(f64, String)> { (0..=4).map(|k| lo + (hi - lo) * f64::from(k) / 4.0).map(|v| (v, format!("{v:.2}"))).collect() };
    for (k, (a, b, name)) in [(0usize, 1usize, "camera path, top view (x, y) m"), (0, 2, "camera path, side view (x, z) m")].into_iter().enumerate() {
        let (xr, yr) = (range(a), range(b));
        let panel = Panel { rect: (90 + 540 * k as i32, 60, 420, 400), x: xr, y: yr };
        panel.axes(&mut img, name, ["x", "x"][k], ["y", "z"][k], &ticks(xr), &ticks(yr));
        for (j, (tname, t)) in traces.iter().enumerate() {
            let line: Vec<(f64, f64)> = t.steps.iter().map(|s| (s.cam_position_m[a], s.cam_position_m[b])).collect();
            panel.line(&mut img, &line, PALETTE[j % PALETTE.len()]);
            text(&mut img, 100 + 540 * k as i32, 70 + 14 * j as i32, tname, PALETTE[j % PALETTE.len()], 1);
            let (u, v) = panel.px(t.goal_position_m[a], t.goal_position_m[b]);
            draw_cross_mut(&mut img, Rgb([0, 160, 0]), u as i32, v as i32);
            draw_hollow_circle_mut(&mut img, (u as i32, v as i32), 6, Rgb([0, 160, 0]));
        }
    }
    png(&img)
}

/// Markdown: the error budget of each trace side by side (final true pose error, final pixel
/// error, hand-eye estimate error, steps, status, time split).
pub fn budget_markdown(traces: &[(&str, &ServoTrace)]) -> String {
    let mut rows: Vec<(String, Vec<String>)> = vec![
        ("status".into(), vec![]),
        ("control updates".into(), vec![]),
        ("final camera position error vs desired, mm".into(), vec![]),
        ("final camera rotation error vs desired, deg".into(), vec![]),
        ("final pixel error RMS / max, px".into(), vec![]),
        ("controller's own estimate at the end, mm / deg".into(), vec![]),
        ("hand-eye estimate error tool_from_cam, mm / deg".into(), vec![]),
        ("hand-eye estimate error world_from_base, mm / deg".into(), vec![]),
        ("steps on the fallback (target lost)".into(), vec![]),
        ("steps outside the joint limits".into(), vec![]),
        ("loop time s (render / detect / law, s)".into(), vec![]),
    ];
    for (_, t) in traces {
        let last = t.last();
        let f = |g: &dyn Fn(&StepRecord) -> String| last.map_or("-".to_string(), g);
        let (r, d, l) = t.time_split_ms();
        let cells = [
            t.status.describe(),
            t.updates.to_string(),
            f(&|s| format!("{:.3}", s.pose_error_mm)),
            f(&|s| format!("{:.4}", s.pose_error_deg)),
            f(&|s| format!("{:.3} / {:.3}", s.pixel_rms_px, s.pixel_max_px)),
            f(&|s| format!("{:.3} / {:.4}", s.est_error_mm, s.est_error_deg)),
            format!("{:.3} / {:.4}", t.handeye_error[0].mm, t.handeye_error[0].deg),
            format!("{:.3} / {:.4}", t.handeye_error[1].mm, t.handeye_error[1].deg),
            t.steps.iter().filter(|s| s.source == Source::Fallback).count().to_string(),
            t.steps.iter().filter(|s| !s.within_limits).count().to_string(),
            format!("{:.2} ({:.2} / {:.2} / {:.2})", t.loop_s, r * 1e-3, d * 1e-3, l * 1e-3),
        ];
        for (row, c) in rows.iter_mut().zip(cells) {
            row.1.push(c);
        }
    }
    let mut out = format!("| |{}\n|---|{}\n", traces.iter().map(|(n, _)| format!(" {n} |")).collect::<String>(), "---|".repeat(traces.len()));
    for (name, cells) in rows {
        out += &format!("| {name} | {} |\n", cells.join(" | "));
    }
    out
}

/// A contact sheet: `frames` (step, thumbnail) in a grid with step labels.
///
/// # Errors
/// Frames of different sizes, or no column.
pub fn contact_sheet(frames: &[(usize, GrayImage)], columns: u32) -> Result<RgbImage, ReportError> {
    let (tw, th) = frames.first().map_or((1, 1), |(_, f)| f.dimensions());
    if columns == 0 || frames.iter().any(|(_, f)| f.dimensions() != (tw, th)) {
        return Err(ReportError::Input { what: "contact sheet", reason: format!("{columns} columns; every frame must be {tw}x{th}") });
    }
    let rows = (frames.len() as u32).div_ceil(columns.max(1)).max(1);
    let mut sheet = RgbImage::from_pixel(columns * (tw + 4), rows * (th + 16), Rgb([255, 255, 255]));
    for (k, (step, f)) in frames.iter().enumerate() {
        let (cx, cy) = ((k as u32 % columns) * (tw + 4), (k as u32 / columns) * (th + 16));
        for (x, y, p) in f.enumerate_pixels() {
            sheet.put_pixel(cx + x, cy + 14 + y, Rgb([p[0], p[0], p[0]]));
        }
        text(&mut sheet, cx as i32 + 2, cy as i32 + 3, &format!("step {step}"), Rgb([0, 0, 0]), 1);
    }
    Ok(sheet)
}
