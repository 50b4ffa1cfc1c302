//! The calibration sweep's tables and plot.

use super::ReportError;
use crate::sim::sweep::{SweepMode, SweepRun};

/// Mean and standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// Markdown table: one row per (mode, M, N), mean +- std over seeds.
pub fn markdown(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> String {
    let mut s = String::from("| mode | M | N | %e fx | %e fy | %e cx | %e cy | RMS px | runs |\n|---|---|---|---|---|---|---|---|---|\n");
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
                s += &format!(
                    "| {} | {m} | {n} | {} | {} | {} | {} | {} | {} |\n",
                    if mode == SweepMode::Ideal { "ideal + 0.5 px" } else { "rendered + detected" },
                    cell(&|r| r.err_pct[0]),
                    cell(&|r| r.err_pct[1]),
                    cell(&|r| r.err_pct[2]),
                    cell(&|r| r.err_pct[3]),
                    cell(&|r| r.rms_px),
                    sel.len()
                );
            }
        }
    }
    s
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
/// PNG encoding.
pub fn plot_png(runs: &[SweepRun], ms: &[usize], ns: &[usize]) -> Result<Vec<u8>, ReportError> {
    use super::plot::{canvas, png, text, Panel, PALETTE};
    let (Some(first), Some(last)) = (ms.first(), ms.last()) else {
        return Err(ReportError::Input { what: "sweep plot", reason: "no M values".into() });
    };
    let mut img = canvas(1100, 520);
    let (ylo, yhi) = (-3.0f64, 2.0f64);
    let xt: Vec<(f64, String)> = ms.iter().map(|m| ((*m as f64).log10(), m.to_string())).collect();
    let yt: Vec<(f64, String)> = (-3..=2).map(|e| (f64::from(e), format!("{}", 10f64.powi(e)))).collect();
    let xr = ((*first as f64).max(1.0).log10() - 0.1, (*last as f64).max(1.0).log10() + 0.1);
    for (k, (mode, name)) in [(SweepMode::Ideal, "ideal + 0.5 px noise"), (SweepMode::Rendered, "rendered + detected")].into_iter().enumerate() {
        let panel = Panel { rect: (90 + 520 * k as i32, 50, 420, 380), x: xr, y: (ylo, yhi) };
        panel.axes(&mut img, name, "views M", "% err fx", &xt, &yt);
        for (j, &n) in ns.iter().enumerate() {
            let pts: Vec<(f64, f64)> = ms
                .iter()
                .filter_map(|&m| {
                    let v: Vec<f64> = runs.iter().filter(|r| r.mode == mode && r.m == m && r.n == n).map(|r| r.err_pct[0]).collect();
                    (!v.is_empty()).then(|| ((m as f64).log10(), (v.iter().sum::<f64>() / v.len() as f64).max(1e-3).log10().clamp(ylo, yhi)))
                })
                .collect();
            panel.line(&mut img, &pts, PALETTE[j % PALETTE.len()]);
            text(&mut img, 90 + 520 * k as i32 + 330, 60 + 14 * j as i32, &format!("N = {n}"), PALETTE[j % PALETTE.len()], 1);
        }
    }
    png(&img)
}
