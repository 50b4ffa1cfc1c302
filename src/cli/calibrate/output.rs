//! The JSON of `calibrate`'s global search, outlier rejection and projection uncertainty.

use serde::Serialize;

#[derive(Debug, Serialize)]
pub(super) struct SearchOut {
    pub(super) starts: usize,
    pub(super) restarts: usize,
    pub(super) restart_improved: bool,
    /// The lowest cost a restart reached over the fit's, on the subsample the restarts use
    /// (>= 1 - 1e-6 unless a restart found a lower optimum).
    pub(super) best_restart_ratio: f64,
}

#[derive(Debug, Serialize)]
pub(super) struct RejectionOut {
    /// Threshold in robust standard deviations; null: rejection off.
    pub(super) threshold_sigmas: Option<f64>,
    pub(super) sigma_px: f64,
    pub(super) threshold_px: f64,
    pub(super) rounds: usize,
    pub(super) dropped: usize,
    /// RMS of the fit with every point, before anything was dropped, px.
    pub(super) rms_before_px: f64,
}

/// The projection uncertainty map ([`synthcam::calib::UncertaintyMap`]).
#[derive(Debug, Serialize)]
pub(super) struct UncertaintyOut {
    /// Range in metres; null: at infinity.
    pub(super) range_m: Option<f64>,
    pub(super) cols: u32,
    pub(super) rows: u32,
    /// Cell size, px.
    pub(super) cell_px: [f64; 2],
    /// Worst-direction sigma at each cell centre, rows of `cols` values, px (null where the lens
    /// cannot map the pixel).
    pub(super) sigma_px: Vec<Vec<Option<f64>>>,
    /// Whether an observed point falls in each cell.
    pub(super) covered: Vec<Vec<bool>>,
    pub(super) worst_inside_px: Option<f64>,
    pub(super) worst_outside_px: Option<f64>,
}

pub(super) fn uncertainty_out(map: &synthcam::calib::UncertaintyMap) -> UncertaintyOut {
    let g = map.grid;
    let finite = |v: f64| v.is_finite().then_some(v);
    UncertaintyOut {
        range_m: map.range,
        cols: g.cols,
        rows: g.rows,
        cell_px: [f64::from(g.size.width) / f64::from(g.cols), f64::from(g.size.height) / f64::from(g.rows)],
        sigma_px: map.sigma_px.chunks(g.cols as usize).map(|r| r.iter().map(|v| finite(*v)).collect()).collect(),
        covered: map.covered.chunks(g.cols as usize).map(<[bool]>::to_vec).collect(),
        worst_inside_px: finite(map.worst_inside_px),
        worst_outside_px: finite(map.worst_outside_px),
    }
}

impl From<&synthcam::calib::Search> for SearchOut {
    fn from(s: &synthcam::calib::Search) -> Self {
        Self { starts: s.starts, restarts: s.restarts, restart_improved: s.restart_improved, best_restart_ratio: s.best_restart_ratio }
    }
}

impl From<&synthcam::calib::Rejection> for RejectionOut {
    fn from(r: &synthcam::calib::Rejection) -> Self {
        Self {
            threshold_sigmas: r.threshold_sigmas,
            sigma_px: r.sigma_px,
            threshold_px: r.threshold_px,
            rounds: r.rounds,
            dropped: r.dropped,
            rms_before_px: r.rms_before_px,
        }
    }
}
