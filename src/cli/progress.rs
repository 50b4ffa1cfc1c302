//! Progress bars for the long commands (datasets, servo runs, sweeps, exports): position, rate and
//! ETA on stderr. indicatif's stderr target draws only when stderr is a terminal, so logs, pipes
//! and CI stay quiet; `SYNTHCAM_PROGRESS=0` hides the bars on a terminal too.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `len` steps counting `unit` ("images", "steps", "calibrations"), labelled `what`.
pub fn bar(len: u64, what: &str, unit: &str) -> ProgressBar {
    let target = if std::env::var("SYNTHCAM_PROGRESS").is_ok_and(|v| v == "0") { ProgressDrawTarget::hidden() } else { ProgressDrawTarget::stderr() };
    let bar = ProgressBar::with_draw_target(Some(len), target);
    let template = format!("{{prefix}} {{bar:32}} {{pos}}/{{len}} {unit}, {{per_sec}}, ETA {{eta}} {{msg}}");
    bar.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    bar.set_prefix(what.to_owned());
    bar
}
