//! What `calibrate` prints: the fit, its warnings and the one-line answers.

use synthcam::calib::{CalibResult, UncertaintyMap};
use synthcam::camera::intrinsic_names;

use super::CalibrateArgs;

/// The names of the parameters the data do not determine.
pub(super) fn undetermined_names(r: &CalibResult) -> Vec<String> {
    let names = intrinsic_names(r.camera.lens.kind());
    let name = |i: usize| names.get(i).map_or_else(|| ["board_warp_x", "board_warp_y"][i.saturating_sub(names.len()).min(1)].to_string(), |n| (*n).to_string());
    r.undetermined.iter().map(|&i| name(i)).collect()
}

/// The summary on the terminal.
pub(super) fn print_result(args: &CalibrateArgs, r: &CalibResult, map: &UncertaintyMap, undetermined: &[String], (used, skipped): (usize, usize)) {
    println!("{used} views used, {skipped} skipped; RMS {:.4} px", r.rms_px);
    if !undetermined.is_empty() {
        eprintln!(
            "warning: {} not determined (standard deviation infinite): the model trades them exactly at this solution, or the views do not vary what they trade against",
            undetermined.join(", ")
        );
    }
    if let (Some(k), true) = (r.rejection.threshold_sigmas, r.rejection.dropped > 0) {
        println!(
            "{} outliers dropped (residual > {:.4} px = {k} robust sigma); RMS with them {:.4} px",
            r.rejection.dropped, r.rejection.threshold_px, r.rejection.rms_before_px
        );
    }
    println!("{}", map.summary());
    if args.board_warp {
        let (k, sd) = (r.board_warp.k, r.board_warp_std);
        println!("board warp: kx {:.3} +- {:.3} mm, ky {:.3} +- {:.3} mm", k[0] * 1e3, sd[0] * 1e3, k[1] * 1e3, sd[1] * 1e3);
    }
    let k = r.camera.intrinsics;
    println!(
        "fx {:.4} +- {:.4}  fy {:.4} +- {:.4}  cx {:.4} +- {:.4}  cy {:.4} +- {:.4}  skew {:.4}",
        k.fx, r.std[0], k.fy, r.std[1], k.cx, r.std[2], k.cy, r.std[3], k.skew
    );
    let n_lens = args.model(0).n_lens_params();
    let lens_names = &r.camera.lens.kind().param_names()[..n_lens];
    println!("{} ({}) = {:?}", args.model(0), lens_names.join(", "), &r.camera.lens.params()[..n_lens]);
}
