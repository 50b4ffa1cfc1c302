//! Servo traces for people and tools: CSV, PNG plots (error per step, singular values, feature
//! tracks, camera path), the side-by-side error budget (ideal vs rendered) and a contact sheet of
//! frames.

use image::{GrayImage, Rgb, RgbImage};
use plotters::prelude::*;

use super::doc::Table;
use super::plot::{clamp, colour, draw_on, figure, int_label, legend, lin_range, log_label, log_range, swatch, FONT};
use super::ReportError;
use synthcam_course::servo_run::{ServoTrace, Source, StepRecord};

/// One CSV row per step (features are in the JSON trace).
pub fn csv(trace: &ServoTrace) -> String {
    let dof = trace.steps.first().map_or(trace.q_start_rad.len(), |s| s.q_rad.len());
    let joints: String = (1..=dof).map(|k| format!("q{k}_rad,")).collect();
    let mut out = format!("step,{joints}cam_x_m,cam_y_m,cam_z_m,pose_error_mm,pose_error_deg,est_error_mm,est_error_deg,pixel_rms_px,pixel_max_px,sigma_min_robot,sigma_min_image,dots,within_limits,source,gain,render_ms,detect_ms,law_ms\n");
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

/// A named quantity of a step.
type Series<'a> = (&'a str, fn(&StepRecord) -> f64);

/// One panel of log series per step for each trace, side by side on the same axes (so no run's
/// curves can hide another's), one colour per series with a legend in each panel.
fn log_series_png(title: &str, ylabel: &str, traces: &[(&str, &ServoTrace)], series: &[Series<'_>]) -> Result<Vec<u8>, ReportError> {
    let panels = traces.len().max(1);
    let n = traces.iter().map(|(_, t)| t.steps.len()).max().unwrap_or(1).max(2) - 1;
    let y = log_range(traces.iter().flat_map(|(_, t)| t.steps.iter().flat_map(|s| series.iter().map(move |(_, f)| f(s)))), 7);
    figure(40 + 560 * panels as u32, 540, |root| {
        let root = root.titled(title, (FONT, 24))?;
        for ((tname, t), area) in traces.iter().zip(root.split_evenly((1, panels))) {
            let mut chart = ChartBuilder::on(&area)
                .caption(*tname, (FONT, 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(0.0..n as f64, (y.0..y.1).log_scale())?;
            chart.configure_mesh().x_desc("step").y_desc(ylabel).x_label_formatter(&int_label).y_label_formatter(&log_label).label_style((FONT, 14)).draw()?;
            for (si, (sname, f)) in series.iter().enumerate() {
                let pts = t.steps.iter().filter_map(|s| clamp(f(s), y).map(|v| (s.step as f64, v)));
                chart.draw_series(LineSeries::new(pts, colour(si).stroke_width(2)))?.label(*sname).legend(swatch(colour(si)));
            }
            legend(&mut chart)?;
        }
        Ok(())
    })
}

/// Error per step: the true pose error (mm, degrees) and the pixel error, for each trace.
///
/// # Errors
/// Drawing or PNG encoding.
pub fn error_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    log_series_png(
        "error per step",
        "error (log)",
        traces,
        &[("pose mm", |s| s.pose_error_mm), ("pose deg", |s| s.pose_error_deg), ("pixel RMS px", |s| s.pixel_rms_px)],
    )
}

/// Smallest singular values of the robot and image Jacobians per step.
///
/// # Errors
/// Drawing or PNG encoding.
pub fn singular_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    log_series_png("smallest singular values", "sigma min (log)", traces, &[("robot J", |s| s.sigma_min_robot), ("image J", |s| s.sigma_min_image)])
}

/// Feature tracks in the image (pixel axes, v down): every dot's measured path over the steps
/// (blue early, red late), the desired features as green circles.
///
/// # Errors
/// An image size of zero, drawing or PNG encoding.
pub fn tracks_png(trace: &ServoTrace, width: u32, height: u32) -> Result<Vec<u8>, ReportError> {
    if width == 0 || height == 0 || width > 16384 || height > 16384 {
        return Err(ReportError::Input { what: "feature tracks", reason: format!("image size {width}x{height}") });
    }
    let (x, y) = ((-0.5, f64::from(width) - 0.5), (-(f64::from(height) - 0.5), 0.5));
    let n = trace.steps.len().max(2) - 1;
    let (w, h) = ((f64::from(width) * 0.6) as u32 + 90, (f64::from(height) * 0.6) as u32 + 100);
    figure(w.max(200), h.max(150), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("feature tracks (blue early, red late; green: desired)", (FONT, 18))
            .margin(12)
            .x_label_area_size(35)
            .y_label_area_size(55)
            .build_cartesian_2d(x.0..x.1, y.0..y.1)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("u px")
            .y_desc("v px")
            .x_label_formatter(&int_label)
            .y_label_formatter(&|v| format!("{:.0}", (-v).max(0.0)))
            .label_style((FONT, 13))
            .draw()?;
        for id in 0..trace.desired_px.len() {
            let pts: Vec<(f64, f64)> = trace
                .steps
                .iter()
                .filter_map(|s| s.features_px.iter().find(|f| f[0] as usize == id))
                .filter_map(|f| Some((clamp(f[1], x)?, clamp(-f[2], y)?)))
                .collect();
            for (k, seg) in pts.windows(2).enumerate() {
                let t = k as f64 / n as f64;
                let c = RGBColor((255.0 * t) as u8, 40, (255.0 * (1.0 - t)) as u8);
                chart.draw_series(LineSeries::new(seg.iter().copied(), c.stroke_width(2)))?;
            }
        }
        let desired = trace.desired_px.iter().flatten().filter_map(|d| Some((clamp(d[0], x)?, clamp(-d[1], y)?)));
        chart.draw_series(desired.map(|p| Circle::new(p, 4, RGBColor(0, 160, 0).stroke_width(1))))?;
        Ok(())
    })
}

/// The camera path seen from above (x, y) and from the side (x, z), with the goal.
///
/// # Errors
/// Drawing or PNG encoding.
pub fn path_png(traces: &[(&str, &ServoTrace)]) -> Result<Vec<u8>, ReportError> {
    let pts: Vec<[f64; 3]> = traces.iter().flat_map(|(_, t)| t.steps.iter().map(|s| s.cam_position_m).chain(std::iter::once(t.goal_position_m))).collect();
    let range = |i: usize| lin_range(pts.iter().map(|p| p[i]), 0.05);
    // Room above the data for the legend.
    let with_legend_room = |(lo, hi): (f64, f64)| (lo, hi + 0.25 * (hi - lo));
    figure(1100, 540, |root| {
        for ((a, b, name), area) in
            [(0usize, 1usize, "camera path, top view (x, y)"), (0, 2, "camera path, side view (x, z)")].into_iter().zip(root.split_evenly((1, 2)))
        {
            let (xr, yr) = (range(a), with_legend_room(range(b)));
            let mut chart = ChartBuilder::on(&area)
                .caption(name, (FONT, 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(65)
                .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)?;
            chart.configure_mesh().x_desc("x m").y_desc(if b == 1 { "y m" } else { "z m" }).label_style((FONT, 13)).draw()?;
            for (j, (tname, t)) in traces.iter().enumerate() {
                let line = t.steps.iter().filter_map(|s| Some((clamp(s.cam_position_m[a], xr)?, clamp(s.cam_position_m[b], yr)?)));
                // Later runs drawn thinner on top, so that a run on the same path leaves the first visible.
                let width = if j == 0 { 4 } else { 1 };
                chart.draw_series(LineSeries::new(line, colour(j).stroke_width(width)))?.label(*tname).legend(swatch(colour(j)));
                if let (Some(u), Some(v)) = (clamp(t.goal_position_m[a], xr), clamp(t.goal_position_m[b], yr)) {
                    chart.draw_series([Cross::new((u, v), 6, RGBColor(0, 160, 0).stroke_width(2))])?;
                }
            }
            legend(&mut chart)?;
        }
        Ok(())
    })
}

/// The error budget of each trace side by side (final true pose error, final pixel error,
/// hand-eye estimate error, steps, status, time split): one column per trace.
pub fn budget_table(traces: &[(&str, &ServoTrace)]) -> Table {
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
    let mut table = Table::new(std::iter::once("").chain(traces.iter().map(|(n, _)| *n)));
    for (name, cells) in rows {
        table.push(std::iter::once(name).chain(cells));
    }
    table
}

/// A contact sheet: `frames` (step, thumbnail) in a grid with step labels.
///
/// # Errors
/// Frames of different sizes, no column, a sheet over 16384 px, or drawing.
pub fn contact_sheet(frames: &[(usize, GrayImage)], columns: u32) -> Result<RgbImage, ReportError> {
    let (tw, th) = frames.first().map_or((1, 1), |(_, f)| f.dimensions());
    let rows = (frames.len() as u32).div_ceil(columns.max(1)).max(1);
    let (w, h) = (u64::from(columns) * u64::from(tw + 4), u64::from(rows) * u64::from(th + 18));
    if columns == 0 || w > 16384 || h > 16384 || frames.iter().any(|(_, f)| f.dimensions() != (tw, th)) {
        return Err(ReportError::Input {
            what: "contact sheet",
            reason: format!("{columns} columns of {tw}x{th} frames (all frames one size, sheet at most 16384 px)"),
        });
    }
    let (w, h) = (w as u32, h as u32);
    let mut sheet = RgbImage::from_pixel(w, h, Rgb([255, 255, 255]));
    let origin = |k: usize| ((k as u32 % columns) * (tw + 4), (k as u32 / columns) * (th + 18));
    for (k, (_, f)) in frames.iter().enumerate() {
        let (cx, cy) = origin(k);
        for (x, y, p) in f.enumerate_pixels() {
            sheet.put_pixel(cx + x, cy + 16 + y, Rgb([p[0], p[0], p[0]]));
        }
    }
    let mut raw = sheet.into_raw();
    draw_on(&mut raw, w, h, |root| {
        for (k, (step, _)) in frames.iter().enumerate() {
            let (cx, cy) = origin(k);
            root.draw(&Text::new(format!("step {step}"), (cx as i32 + 2, cy as i32 + 2), (FONT, 12)))?;
        }
        Ok(())
    })?;
    RgbImage::from_raw(w, h, raw).ok_or_else(|| ReportError::Encode("contact sheet buffer".into()))
}
