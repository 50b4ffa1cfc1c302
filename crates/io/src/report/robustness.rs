//! The robustness experiment's table, CSV and plots ([`synthcam_sim::robustness`]).

use super::doc::Table;
use super::ReportError;
use synthcam_sim::robustness::{Effect, RobustnessRun};

/// The runs of one (effect, level), summarised over the views.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelSummary {
    /// The effect.
    pub effect: Effect,
    /// The level.
    pub level: f64,
    /// Mean strength over the views.
    pub strength: f64,
    /// Views run.
    pub views: usize,
    /// Views where the board was found.
    pub detected: usize,
    /// Mean of the per-view RMS corner errors over the detections, px (NaN without one).
    pub mean_rms_px: f64,
    /// Largest corner error over the detections, px (NaN without one).
    pub max_px: f64,
    /// Untrusted corners over the detections (left out of the errors).
    pub untrusted: usize,
}

impl LevelSummary {
    /// Detection rate, percent.
    pub fn detection_pct(&self) -> f64 {
        100.0 * self.detected as f64 / self.views.max(1) as f64
    }
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.filter(|x| x.is_finite()).fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        s / n as f64
    }
}

/// One summary per (effect, level) in the order they first appear in `runs`.
pub fn summarise(runs: &[RobustnessRun]) -> Vec<LevelSummary> {
    let mut keys: Vec<(Effect, f64)> = Vec::new();
    for r in runs {
        if !keys.iter().any(|(e, l)| *e == r.effect && l.to_bits() == r.level.to_bits()) {
            keys.push((r.effect, r.level));
        }
    }
    keys.into_iter()
        .map(|(effect, level)| {
            let sel: Vec<&RobustnessRun> = runs.iter().filter(|r| r.effect == effect && r.level.to_bits() == level.to_bits()).collect();
            let found: Vec<&&RobustnessRun> = sel.iter().filter(|r| r.detected).collect();
            LevelSummary {
                effect,
                level,
                strength: mean(sel.iter().map(|r| r.strength)),
                views: sel.len(),
                detected: found.len(),
                mean_rms_px: mean(found.iter().map(|r| r.rms_px)),
                max_px: found.iter().map(|r| r.max_px).fold(f64::NAN, f64::max),
                untrusted: found.iter().map(|r| r.untrusted).sum(),
            }
        })
        .collect()
}

/// A number for a table cell: `-` for NaN.
fn cell(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.digits$}")
    }
}

/// A level as written in tables and file names (`1.5`, `0.00004`, `100`).
pub fn level_label(level: f64) -> String {
    let s = format!("{level:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The table: per effect and level, the strength, detection rate, mean RMS and max error.
pub fn table(runs: &[RobustnessRun]) -> Table {
    let mut t = Table::new(["effect", "level", "strength", "detected %", "mean RMS px", "max px", "untrusted corners", "views"]);
    for l in summarise(runs) {
        t.push([
            l.effect.name().to_string(),
            format!("{} {}", level_label(l.level), l.effect.level_name()),
            cell(l.strength, 3),
            format!("{:.0}", l.detection_pct()),
            cell(l.mean_rms_px, 4),
            cell(l.max_px, 4),
            l.untrusted.to_string(),
            l.views.to_string(),
        ]);
    }
    t
}

/// The header of [`csv`].
pub const CSV_HEADER: &str = "effect,level,strength,view,detected,rms_px,max_px,n_corners,untrusted";

/// CSV: one line per run (empty error fields when not detected).
pub fn csv(runs: &[RobustnessRun]) -> String {
    let num = |v: f64| if v.is_finite() { format!("{v:.6}") } else { String::new() };
    let mut s = format!("{CSV_HEADER}\n");
    for r in runs {
        s += &format!(
            "{},{},{},{},{},{},{},{},{}\n",
            r.effect.name(),
            level_label(r.level),
            num(r.strength),
            r.view,
            u8::from(r.detected),
            num(r.rms_px),
            num(r.max_px),
            r.n_corners,
            r.untrusted
        );
    }
    s
}

/// The plot of one effect: mean RMS corner error (log scale, left) and detection rate (right)
/// against the strength.
///
/// # Errors
/// No run of `effect`, drawing or PNG encoding.
pub fn plot_png(runs: &[RobustnessRun], effect: Effect) -> Result<Vec<u8>, ReportError> {
    use super::plot::{clamp, colour, figure, lin_range, log_label, log_range, FONT};
    use plotters::prelude::*;
    let levels: Vec<LevelSummary> = summarise(runs).into_iter().filter(|l| l.effect == effect).collect();
    if levels.is_empty() {
        return Err(ReportError::Input { what: "robustness plot", reason: format!("no run of {}", effect.name()) });
    }
    let x = lin_range(levels.iter().map(|l| l.strength), 1.0);
    let y_rms = log_range(levels.iter().map(|l| l.mean_rms_px), 4);
    let y_det = (0.0, 105.0);
    let rms_pts: Vec<(f64, f64)> = levels.iter().filter_map(|l| Some((clamp(l.strength, x)?, clamp(l.mean_rms_px, y_rms)?))).collect();
    let det_pts: Vec<(f64, f64)> = levels.iter().filter_map(|l| Some((clamp(l.strength, x)?, l.detection_pct()))).collect();
    figure(1100, 460, |root| {
        let root = root.titled(&format!("{}: synthcam chessboard detector", effect.name()), (FONT, 22))?;
        let areas = root.split_evenly((1, 2));
        let mut left =
            ChartBuilder::on(&areas[0]).margin(12).x_label_area_size(40).y_label_area_size(70).build_cartesian_2d(x.0..x.1, (y_rms.0..y_rms.1).log_scale())?;
        left.configure_mesh()
            .x_desc(effect.strength_name())
            .y_desc("mean RMS corner error, px")
            .y_label_formatter(&log_label)
            .label_style((FONT, 14))
            .draw()?;
        left.draw_series(LineSeries::new(rms_pts.iter().copied(), colour(0).stroke_width(2)))?;
        left.draw_series(rms_pts.iter().map(|p| Circle::new(*p, 4, colour(0).filled())))?;
        let mut right = ChartBuilder::on(&areas[1]).margin(12).x_label_area_size(40).y_label_area_size(70).build_cartesian_2d(x.0..x.1, y_det.0..y_det.1)?;
        right.configure_mesh().x_desc(effect.strength_name()).y_desc("detection rate, %").label_style((FONT, 14)).draw()?;
        right.draw_series(LineSeries::new(det_pts.iter().copied(), colour(1).stroke_width(2)))?;
        right.draw_series(det_pts.iter().map(|p| Circle::new(*p, 4, colour(1).filled())))?;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(effect: Effect, level: f64, view: usize, detected: bool, rms_px: f64) -> RobustnessRun {
        let nan = f64::NAN;
        let (rms_px, max_px) = if detected { (rms_px, 2.0 * rms_px) } else { (nan, nan) };
        RobustnessRun { effect, level, strength: level, view, detected, rms_px, max_px, n_corners: if detected { 88 } else { 0 }, untrusted: 0 }
    }

    #[test]
    fn summaries_tables_and_plots() {
        let runs = vec![
            run(Effect::Blur, 0.0, 0, true, 0.01),
            run(Effect::Blur, 0.0, 1, true, 0.03),
            run(Effect::Blur, 3.0, 0, false, 0.0),
            run(Effect::Blur, 3.0, 1, true, 0.1),
        ];
        let s = summarise(&runs);
        assert_eq!(s.len(), 2);
        assert!((s[0].mean_rms_px - 0.02).abs() < 1e-12 && s[0].detection_pct() == 100.0 && (s[0].max_px - 0.06).abs() < 1e-12);
        assert_eq!((s[1].detected, s[1].views, s[1].detection_pct()), (1, 2, 50.0));
        let md = table(&runs).markdown();
        assert!(md.contains("| blur | 3 sigma px | 3.000 | 50 | 0.1000 | 0.2000 | 0 | 2 |"), "{md}");
        let c = csv(&runs);
        assert!(c.starts_with(CSV_HEADER) && c.contains("\nblur,3,3.000000,0,0,,,0,0\n"), "{c}");
        assert_eq!(level_label(4e-5), "0.00004");
        let png = plot_png(&runs, Effect::Blur).expect("plot");
        assert!(image::load_from_memory(&png).is_ok());
        assert!(plot_png(&runs, Effect::Jpeg).is_err());
    }
}
