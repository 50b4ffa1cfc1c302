//! The calibration sweep's tables and plot.

use super::doc::Table;
use super::ReportError;
use synthcam_course::sweep::{SweepMode, SweepRun};

/// Mean and standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// The table: one row per (mode, M, N), mean +- std over seeds.
pub fn table(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> Table {
    let mut t = Table::new(["mode", "M", "N", "%e fx", "%e fy", "%e cx", "%e cy", "RMS px", "runs"]);
    for mode in [SweepMode::Ideal, SweepMode::Rendered] {
        for &m in ms {
            for &n in ns {
                let sel: Vec<&SweepRun> = runs.iter().filter(|r| r.mode == mode && r.m == m && r.n == n).collect();
                if sel.is_empty() {
                    continue;
                }
                let cell = |f: &dyn Fn(&SweepRun) -> f64| {
                    let (a, b) = mean_std(&sel.iter().map(|r| f(r)).collect::<Vec<_>>());
                    format!("{a:.3} +- {b:.3}")
                };
                t.push([
                    if mode == SweepMode::Ideal { "ideal + 0.5 px" } else { "rendered + detected" }.to_string(),
                    m.to_string(),
                    n.to_string(),
                    cell(&|r| r.err_pct[0]),
                    cell(&|r| r.err_pct[1]),
                    cell(&|r| r.err_pct[2]),
                    cell(&|r| r.err_pct[3]),
                    cell(&|r| r.rms_px),
                    sel.len().to_string(),
                ]);
            }
        }
    }
    t
}

/// CSV: one line per calibration.
pub fn csv(runs: &[SweepRun]) -> String {
    let mut s = String::from("mode,M,N,seed,err_fx_pct,err_fy_pct,err_cx_pct,err_cy_pct,rms_px\n");
    for r in runs {
        s += &format!(
            "{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            if r.mode == SweepMode::Ideal { "ideal" } else { "rendered" },
            r.m,
            r.n,
            r.seed,
            r.err_pct[0],
            r.err_pct[1],
            r.err_pct[2],
            r.err_pct[3],
            r.rms_px
        );
    }
    s
}

/// The sweep as a PNG: mean % error of fx against M (log-log), one line per N, one panel per mode.
///
/// # Errors
/// No positive M value, drawing or PNG encoding.
pub fn plot_png(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> Result<Vec<u8>, ReportError> {
    use super::plot::{clamp, colour, figure, int_label, legend, log_label, swatch, FONT};
    use plotters::prelude::*;
    let (Some(lo), Some(hi)) = (ms.iter().copied().filter(|m| *m > 0).min(), ms.iter().copied().max()) else {
        return Err(ReportError::Input { what: "sweep plot", reason: format!("no positive M value in {ms:?}") });
    };
    let x = (lo as f64 / 1.2, hi as f64 * 1.2);
    let y = (1e-3, 1e2);
    figure(1100, 540, |root| {
        for ((mode, name), area) in
            [(SweepMode::Ideal, "ideal + 0.5 px noise"), (SweepMode::Rendered, "rendered + detected")].into_iter().zip(root.split_evenly((1, 2)))
        {
            let mut chart = ChartBuilder::on(&area)
                .caption(name, (FONT, 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d((x.0..x.1).log_scale(), (y.0..y.1).log_scale())?;
            chart
                .configure_mesh()
                .x_desc("views M")
                .y_desc("mean % error of fx")
                .x_label_formatter(&int_label)
                .y_label_formatter(&log_label)
                .label_style((FONT, 14))
                .draw()?;
            for (j, &n) in ns.iter().enumerate() {
                let pts: Vec<(f64, f64)> = ms
                    .iter()
                    .filter(|m| **m > 0)
                    .filter_map(|&m| {
                        let v: Vec<f64> = runs.iter().filter(|r| r.mode == mode && r.m == m && r.n == n).map(|r| r.err_pct[0]).collect();
                        if v.is_empty() {
                            return None;
                        }
                        Some((m as f64, clamp(v.iter().sum::<f64>() / v.len() as f64, y)?))
                    })
                    .collect();
                chart.draw_series(LineSeries::new(pts.iter().copied(), colour(j).stroke_width(2)))?.label(format!("N = {n}")).legend(swatch(colour(j)));
                chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, colour(j).filled())))?;
            }
            legend(&mut chart)?;
        }
        Ok(())
    })
}
