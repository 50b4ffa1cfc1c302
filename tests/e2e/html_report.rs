//! `report.html` of `servo`, `calibrate --report`, `experiment robustness`, `experiment
//! calib-sweep` and `demo`: one self-contained page each (tables, plots and frames as `data:`
//! URIs, inline CSS, no network resource), opened in headless Chromium: the DOM holds the tables
//! and images, and the screenshot is not blank.
//!
//! Without Chromium (`chromium` or `chromium-browser` on the PATH) the browser checks say that
//! they skipped, unless `SYNTHCAM_CHROMIUM=1` (CI sets it), where a missing browser fails.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::bin;

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("synthcam-html-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Run synthcam with `args`; panics with its output unless it exits 0.
fn synthcam(args: &[&std::ffi::OsStr]) {
    let o = Command::new(bin()).args(args).env("NODEVICE_SELECT", "1").output().expect("run synthcam");
    let text = String::from_utf8_lossy(&o.stderr).into_owned() + &String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "synthcam {args:?}: exit {:?}: {text}", o.status);
}

/// The page's static checks: `tables` tables and at least `images` images, every one a PNG
/// data URI that decodes, the `headings` present, no network resource. Returns the page.
fn check_page(path: &Path, tables: usize, images: usize, headings: &[&str]) -> String {
    let html = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"), "{}: not a whole page", path.display());
    assert_eq!(html.matches("<table>").count(), tables, "{}: tables", path.display());
    assert_eq!(html.matches("<table>").count(), html.matches("</table>").count());
    for h in headings {
        assert!(html.contains(h), "{}: no `{h}`", path.display());
    }
    let srcs: Vec<&str> = html.split("<img ").skip(1).map(|s| s.split(" src=\"").nth(1).and_then(|s| s.split('"').next()).expect("src")).collect();
    assert!(srcs.len() >= images, "{}: {} images, expected at least {images}", path.display(), srcs.len());
    for src in &srcs {
        let b64 = src.strip_prefix("data:image/png;base64,").unwrap_or_else(|| panic!("{}: image not a PNG data URI: {:.80}", path.display(), src));
        use base64::Engine as _;
        let png = base64::engine::general_purpose::STANDARD.decode(b64).expect("base64");
        image::load_from_memory(&png).expect("the embedded PNG decodes");
    }
    let lower = html.to_ascii_lowercase();
    for attr in ["src=", "href=", "url("] {
        for scheme in ["http:", "https:", "//"] {
            for q in ["\"", "'", ""] {
                assert!(!lower.contains(&format!("{attr}{q}{scheme}")), "{}: a network resource ({attr}{q}{scheme})", path.display());
            }
        }
    }
    assert!(!lower.contains("<script") && !lower.contains("<link"), "{}: a script or linked resource", path.display());
    eprintln!("{}: {} bytes, {tables} tables, {} images", path.display(), html.len(), srcs.len());
    html
}

/// The Chromium binary, or `None` (after saying why) when there is none and CI does not ask for it.
fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser"].into_iter().find(|c| Command::new(c).arg("--version").output().is_ok_and(|o| o.status.success()));
    if found.is_none() {
        assert!(
            std::env::var("SYNTHCAM_CHROMIUM").ok().as_deref() != Some("1"),
            "SYNTHCAM_CHROMIUM=1 but no chromium on the PATH (apt-get install -y --no-install-recommends chromium)"
        );
        eprintln!("skipped the browser check: no chromium or chromium-browser on the PATH (apt-get install -y --no-install-recommends chromium)");
    }
    found
}

/// Headless Chromium with a private profile under `dir`.
fn headless(browser: &str, dir: &Path) -> Command {
    let mut c = Command::new(browser);
    c.args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run", "--disable-extensions"])
        .arg(format!("--user-data-dir={}", dir.join("chromium-profile").display()))
        .env("HOME", dir);
    c
}

/// Open `page` in headless Chromium: the DOM it builds holds `tables` tables and at least
/// `images` images, and a 1280 x 2400 screenshot is not blank (many colours, 3 % or more of the pixels
/// not white, some dark).
fn check_in_chromium(page: &Path, tables: usize, images: usize) {
    let Some(browser) = chromium() else { return };
    let t0 = std::time::Instant::now();
    let dir = page.parent().expect("folder");
    let url = format!("file://{}", page.canonicalize().expect("absolute").display());
    let o = headless(browser, dir).args(["--dump-dom", &url]).output().expect("run chromium");
    let dom = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && dom.contains("</html>"), "chromium --dump-dom: {:?}: {}", o.status, String::from_utf8_lossy(&o.stderr));
    assert_eq!(dom.matches("<table>").count(), tables, "tables in the DOM");
    assert!(dom.matches("<img ").count() >= images, "images in the DOM");
    assert!(dom.matches("<th>").count() >= tables && dom.contains("<td>"), "table cells in the DOM");
    let shot = dir.join("screenshot.png");
    let o =
        headless(browser, dir).args(["--window-size=1280,2400".to_string(), format!("--screenshot={}", shot.display()), url]).output().expect("run chromium");
    assert!(o.status.success(), "chromium --screenshot: {:?}: {}", o.status, String::from_utf8_lossy(&o.stderr));
    let img = image::open(&shot).expect("the screenshot is a PNG").to_rgb8();
    let n = img.pixels().count() as f64;
    let non_white = img.pixels().filter(|p| p.0.iter().any(|&c| c < 245)).count() as f64 / n;
    let dark = img.pixels().filter(|p| p.0.iter().all(|&c| c < 100)).count() as f64 / n;
    let colours: std::collections::HashSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    eprintln!(
        "{}: screenshot {}x{}, {:.1} % not white, {:.2} % dark, {} colours; chromium {:.1} s",
        page.display(),
        img.width(),
        img.height(),
        100.0 * non_white,
        100.0 * dark,
        colours.len(),
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(img.dimensions(), (1280, 2400));
    assert!(colours.len() > 50, "{} colours: a blank page", colours.len());
    assert!(non_white > 0.03 && dark > 0.001, "{:.3} not white, {:.4} dark: a blank page", non_white, dark);
}

#[test]
fn servo_report_renders_in_chromium() {
    let out = out_dir("servo");
    let args = ["servo", "--law", "pbvs", "--steps", "5", "--no-stop", "--true-handeye", "--frames", "-o"];
    synthcam(&args.iter().map(std::ffi::OsStr::new).chain([out.as_os_str()]).collect::<Vec<_>>());
    // The budget, four plots, the contact sheet and the first and last frames.
    let html =
        check_page(&out.join("report.html"), 1, 7, &["<th>rendered + detected</th>", "<th>ideal + 0.1 px</th>", "control updates", "last rendered frame"]);
    assert!(html.contains("<figcaption>error per step</figcaption>"));
    let md = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    assert!(md.contains("| control updates | 5 | 5 |") && md.contains("![error per step](error.png)"), "{md}");
    check_in_chromium(&out.join("report.html"), 1, 7);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn calibrate_report_renders_in_chromium() {
    let out = out_dir("calibrate");
    let images = out.join("images");
    crate::common::write_chessboard_views(&images);
    let report = out.join("report");
    let args =
        [images.as_os_str(), "--target".as_ref(), "chessboard:8x6".as_ref(), "--square".as_ref(), "0.03".as_ref(), "--report".as_ref(), report.as_os_str()];
    synthcam(&std::iter::once("calibrate".as_ref()).chain(args).collect::<Vec<_>>());
    // Intrinsics, views, skipped (v6.png at 641 x 481); the residual plot (and the uncertainty map).
    check_page(&report.join("report.html"), 3, 1, &["<h2>Intrinsics</h2>", "<td>v5.png</td>", "<td>v6.png</td>", "641x481", "<td>fx</td>"]);
    let md = std::fs::read_to_string(report.join("report.md")).expect("report.md");
    assert!(md.contains("| view | file | points | outliers | RMS px | max px |") && md.contains("![reprojection error"), "{md}");
    assert!(report.join("calibration.png").exists());
    check_in_chromium(&report.join("report.html"), 3, 1);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn robustness_report_renders_in_chromium() {
    let out = out_dir("robustness");
    let args = ["experiment", "robustness", "--views", "1", "--effects", "blur", "--images", "false", "-o"];
    synthcam(&args.iter().map(std::ffi::OsStr::new).chain([out.as_os_str()]).collect::<Vec<_>>());
    // The table, the blur plot, view 0 at the weakest and strongest blur.
    let html = check_page(&out.join("report.html"), 1, 3, &["<th>detected %</th>", "<td>blur</td>", "view 0"]);
    let table = std::fs::read_to_string(out.join("table.md")).expect("table.md");
    // Every markdown row is a row of the HTML table (one structure writes both).
    assert_eq!(table.lines().count() - 2, html.matches("<tr><td>").count(), "{table}");
    check_in_chromium(&out.join("report.html"), 1, 3);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn calib_sweep_report_renders_in_chromium() {
    let out = out_dir("calib-sweep");
    synthcam(&["experiment".as_ref(), "calib-sweep".as_ref(), "--seeds".as_ref(), "1".as_ref(), "-o".as_ref(), out.as_os_str()]);
    // One row per (mode, M, N): 2 modes x 5 M x 4 N; the fx error plot.
    let html = check_page(&out.join("report.html"), 1, 1, &["<th>%e fx</th>", "<td>rendered + detected</td>", "<td>ideal + 0.5 px</td>"]);
    assert_eq!(html.matches("<tr><td>").count(), 40);
    let table = std::fs::read_to_string(out.join("table.md")).expect("table.md");
    assert_eq!(table.lines().count() - 2, 40, "{table}");
    check_in_chromium(&out.join("report.html"), 1, 1);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn demo_report_holds_every_section() {
    let t0 = std::time::Instant::now();
    let out = out_dir("demo");
    synthcam(&["demo".as_ref(), "-o".as_ref(), out.as_os_str()]);
    // Render + detect, calibration, hand-eye, the PBVS and IBVS budgets; two scene frames and
    // four plots per law.
    let headings =
        ["<h2>Render and detect</h2>", "<h2>Hand-eye (course variant A, 5 rendered views)</h2>", "<h2>PBVS from", "<h2>IBVS from", "<td>estimate</td>"];
    check_page(&out.join("report.html"), 5, 10, &headings);
    for law in ["pbvs", "ibvs"] {
        check_page(&out.join(law).join("report.html"), 1, 4, &["control updates"]);
    }
    let md = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(md.contains("![error per step](pbvs/error.png)") && md.contains("![course_s_path: rendered frame](course_s_path.png)"), "{md}");
    assert_eq!(md.lines().filter(|l| l.starts_with("|---|")).count(), 5, "{md}");
    check_in_chromium(&out.join("report.html"), 5, 10);
    eprintln!("demo and its report checks: {:.1} s", t0.elapsed().as_secs_f64());
    let _ = std::fs::remove_dir_all(&out);
}
