//! Calibration results as a plot and a report (the camera files are `camera::formats`).

use super::doc::{Document, Table};
use synthcam_core::camera::{intrinsic_names, BASE_INTRINSIC_NAMES};
use synthcam_geometry::calib::{CalibResult, UncertaintyMap};

/// The calibration as a PNG: per-view RMS and max reprojection error (bars) and every residual
/// vector drawn at its corner in the image frame, magnified so the largest is 5 % of the image width.
///
/// # Errors
/// Drawing or PNG encoding.
pub fn plot_png(r: &CalibResult, points_px: &[Vec<nalgebra::Point2<f64>>]) -> Result<Vec<u8>, super::ReportError> {
    use super::plot::{clamp, colour, figure, int_label, legend, FONT};
    use plotters::prelude::*;
    let n = r.views.len().max(1);
    let ymax = r.views.iter().map(|v| v.max_px).filter(|v| v.is_finite()).fold(1e-6, f64::max) * 1.15;
    let (iw, ih) = (f64::from(r.camera.size.width).max(1.0), f64::from(r.camera.size.height).max(1.0));
    let big = r.views.iter().flat_map(|v| v.residuals_px.iter().map(|e| e.norm())).filter(|v| v.is_finite()).fold(1e-9, f64::max);
    // Residual vectors magnified so that the largest is 5 % of the image width.
    let mag = 0.05 * iw / big;
    figure(1200, 560, |root| {
        let (left, right) = root.split_horizontally(540);
        let mut bars = ChartBuilder::on(&left)
            .caption("reprojection error per view", (FONT, 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(65)
            .build_cartesian_2d(-0.5..n as f64 - 0.5, 0.0..ymax)?;
        bars.configure_mesh().disable_x_mesh().x_desc("view").y_desc("px").x_label_formatter(&int_label).label_style((FONT, 14)).draw()?;
        let bar = |i: usize, v: f64, half: f64| Some([(i as f64 - half, 0.0), (i as f64 + half, clamp(v, (0.0, ymax))?)]);
        let grey = RGBColor(190, 190, 190);
        bars.draw_series(r.views.iter().enumerate().filter_map(|(i, v)| bar(i, v.max_px, 0.4)).map(|c| Rectangle::new(c, grey.filled())))?
            .label("max")
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], grey.filled()));
        bars.draw_series(r.views.iter().enumerate().filter_map(|(i, v)| bar(i, v.rms_px, 0.2)).map(|c| Rectangle::new(c, colour(0).filled())))?
            .label("RMS")
            .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], colour(0).filled()));
        legend(&mut bars)?;
        let title = format!("residuals in the image, x{mag:.0}");
        let mut frame =
            ChartBuilder::on(&right).caption(title, (FONT, 20)).margin(12).x_label_area_size(40).y_label_area_size(60).build_cartesian_2d(0.0..iw, ih..0.0)?;
        frame.configure_mesh().disable_mesh().x_desc("u px").y_desc("v px").label_style((FONT, 14)).draw()?;
        for (k, (v, pts)) in r.views.iter().zip(points_px).enumerate() {
            let arrows = v.residuals_px.iter().zip(pts).filter_map(|(e, p)| {
                let (u0, v0) = (clamp(p.x, (0.0, iw))?, clamp(p.y, (0.0, ih))?);
                Some(PathElement::new(vec![(u0, v0), (clamp(p.x + mag * e.x, (0.0, iw))?, clamp(p.y + mag * e.y, (0.0, ih))?)], colour(k)))
            });
            frame.draw_series(arrows)?;
        }
        Ok(())
    })
}

/// What the calibration report shows besides the result.
#[derive(Debug, Clone, Copy)]
pub struct CalibInputs<'a> {
    /// The lens model estimated (its name).
    pub model: &'a str,
    /// How many lens parameters the model estimates (the first of the lens's parameters).
    pub lens_params: usize,
    /// The file of each view.
    pub files: &'a [String],
    /// Each view's detected points, pixels.
    pub points_px: &'a [Vec<nalgebra::Point2<f64>>],
    /// The inputs left out: (file, reason).
    pub skipped: &'a [(String, String)],
    /// The projection uncertainty over the image, if computed.
    pub uncertainty: Option<&'a UncertaintyMap>,
}

/// The projection uncertainty map as a PNG: each cell coloured by its worst-direction sigma
/// (viridis on a log scale from the smallest to the largest finite value: the covered area and
/// the extrapolated corners differ by orders of magnitude), cells the views cover outlined.
///
/// # Errors
/// Drawing or PNG encoding.
pub fn uncertainty_png(map: &UncertaintyMap) -> Result<Vec<u8>, super::ReportError> {
    use super::plot::{figure, FONT};
    use plotters::prelude::*;
    use plotters::style::colors::colormaps::ViridisRGB;
    let g = map.grid;
    let (iw, ih) = (f64::from(g.size.width).max(1.0), f64::from(g.size.height).max(1.0));
    let (cw, ch) = (iw / f64::from(g.cols.max(1)), ih / f64::from(g.rows.max(1)));
    let finite = || map.sigma_px.iter().copied().filter(|v| v.is_finite() && *v > 0.0);
    let (lo, hi) = (finite().fold(f64::INFINITY, f64::min).min(1e300), finite().fold(1e-300, f64::max));
    let title = format!("projection sigma, px (log scale, {lo:.3} to {hi:.3}); covered cells outlined");
    figure(900, (900.0 * ih / iw) as u32 + 60, |root| {
        let mut c =
            ChartBuilder::on(root).caption(title, (FONT, 18)).margin(12).x_label_area_size(36).y_label_area_size(56).build_cartesian_2d(0.0..iw, ih..0.0)?;
        c.configure_mesh().disable_mesh().x_desc("u px").y_desc("v px").label_style((FONT, 14)).draw()?;
        let cell = |k: usize| {
            let (x, y) = ((k % g.cols as usize) as f64 * cw, (k / g.cols as usize) as f64 * ch);
            [(x, y), (x + cw, y + ch)]
        };
        c.draw_series(map.sigma_px.iter().enumerate().map(|(k, s)| {
            let fill =
                if s.is_finite() { ViridisRGB::get_color_normalized(s.max(lo).ln(), lo.ln(), hi.ln().max(lo.ln() + 1e-9)) } else { RGBColor(60, 60, 60) };
            Rectangle::new(cell(k), fill.filled())
        }))?;
        c.draw_series(map.covered.iter().enumerate().filter(|(_, c)| **c).map(|(k, _)| Rectangle::new(cell(k), WHITE.stroke_width(1))))?;
        Ok(())
    })
}

/// The calibration report: a summary, the estimated intrinsics with their standard deviations,
/// each view's reprojection error, the inputs left out and the plot of [`plot_png`].
///
/// # Errors
/// Drawing or PNG encoding of the plot.
pub fn document(r: &CalibResult, inputs: &CalibInputs<'_>) -> Result<Document, super::ReportError> {
    let cam = &r.camera;
    let mut doc = Document::new("synthcam calibration");
    doc.paragraph(format!(
        "{} views used, {} skipped; model {}; image {}x{} px; RMS reprojection error {:.4} px; {} iterations, {}.",
        r.views.len(),
        inputs.skipped.len(),
        inputs.model,
        cam.size.width,
        cam.size.height,
        r.rms_px,
        r.iterations,
        if r.converged { "converged" } else { "not converged" }
    ));
    doc.paragraph(search_line(r));
    doc.heading(2, "Intrinsics");
    let k = cam.intrinsics;
    let values = [k.fx, k.fy, k.cx, k.cy, k.skew].into_iter().chain(cam.lens.params());
    let n = BASE_INTRINSIC_NAMES.len() + inputs.lens_params;
    let mut t = Table::new(["parameter", "estimate", "std"]);
    for ((name, v), s) in intrinsic_names(cam.lens.kind()).into_iter().zip(values).zip(r.std).take(n) {
        t.push([name.to_string(), format!("{v:.6}"), if s.is_finite() { format!("{s:.6}") } else { "fixed".into() }]);
    }
    doc.table(t);
    doc.heading(2, "Views");
    let mut t = Table::new(["view", "file", "points", "outliers", "RMS px", "max px"]);
    for (i, (v, file)) in r.views.iter().zip(inputs.files).enumerate() {
        let points = inputs.points_px.get(i).map_or(0, Vec::len);
        t.push([i.to_string(), file.clone(), points.to_string(), v.outliers.len().to_string(), format!("{:.4}", v.rms_px), format!("{:.4}", v.max_px)]);
    }
    doc.table(t);
    outliers_section(&mut doc, r, inputs.files);
    if let Some(map) = inputs.uncertainty {
        doc.heading(2, "Projection uncertainty");
        doc.paragraph(map.summary());
        doc.image("worst-direction projection sigma over the image", Some("uncertainty.png".into()), uncertainty_png(map)?);
    }
    if !inputs.skipped.is_empty() {
        doc.heading(2, "Skipped inputs");
        let mut t = Table::new(["file", "reason"]);
        for (file, reason) in inputs.skipped {
            t.push([file.as_str(), reason.as_str()]);
        }
        doc.table(t);
    }
    doc.heading(2, "Reprojection errors");
    doc.image("reprojection error per view and residual vectors", Some("calibration.png".into()), plot_png(r, inputs.points_px)?);
    Ok(doc)
}

/// How the optimum was searched for and what the outlier rejection did, in one paragraph.
fn search_line(r: &CalibResult) -> String {
    let s = &r.search;
    let rj = &r.rejection;
    let restart = if s.restart_improved { "a restart found a lower optimum, which is the result" } else { "no restart ended lower" };
    let outliers = match rj.threshold_sigmas {
        Some(k) => format!(
            "outliers beyond {k} robust sigma ({:.4} px, threshold {:.4} px): {} dropped in {} rounds; RMS with every point {:.4} px",
            rj.sigma_px, rj.threshold_px, rj.dropped, rj.rounds, rj.rms_before_px
        ),
        None => "outlier rejection off (every point kept)".into(),
    };
    format!("Optimum: {} starts, {} perturbed restarts, {restart}. {outliers}.", s.starts, s.restarts)
}

/// The points dropped as outliers, per view (none: no section).
fn outliers_section(doc: &mut Document, r: &CalibResult, files: &[String]) {
    if r.rejection.dropped == 0 {
        return;
    }
    doc.heading(2, "Outliers");
    let mut t = Table::new(["view", "file", "point", "residual px"]);
    for (i, (v, file)) in r.views.iter().zip(files).enumerate() {
        for &j in &v.outliers {
            let residual = v.residuals_px.get(j).map_or(f64::NAN, |e| e.norm());
            t.push([i.to_string(), file.clone(), j.to_string(), format!("{residual:.3}")]);
        }
    }
    doc.table(t);
}
