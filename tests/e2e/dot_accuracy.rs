//! Dot detection on S-path renders from course-like poses (the desired view orbited about the
//! sphere's centre by up to +-15 degrees), beads and painted discs, noise sigma 1 grey level:
//! recall of dots with an image radius >= 1.5 px, false dots, and centre error against the truth
//! centroid (`centroid_px`) and the projected centre (`pixel_px`).

use nalgebra::{Isometry3, Point2, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::camera::Distortion;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;
use synthcam::sim::observe::{pose_from_dots, Dots};
use synthcam::target::{DotStyle, Target};

use crate::common::renderer;

struct Stats {
    eligible: usize,
    recalled: usize,
    false_dots: usize,
    centroid_err: Vec<f64>,
    projected_err: Vec<f64>,
    /// Vs the truth centroid, dots of image radius >= 1.5 px only (those the recall counts).
    eligible_err: Vec<f64>,
    /// Vs the projected centre after the model's centroid-bias correction at the pose PnP finds
    /// from the detected dots (`sim::observe::pose_from_dots`, two rounds).
    corrected_err: Vec<f64>,
}

fn run(style: DotStyle, views: usize, seed: u64) -> Stats {
    run_with(style, views, seed, [0.0; 5], 0.0)
}

/// As [`run`], with lens distortion `dist` (OpenCV order) and the target shifted in the camera's
/// image plane by up to `shift_m` metres each way (parts of the S leave the frame).
fn run_with(style: DotStyle, views: usize, seed: u64, dist: [f64; 5], shift_m: f64) -> Stats {
    let base = parse_scene(include_str!("../../assets/scenes/course_s_path.toml")).expect("scene");
    let world_from_cam0 = base.cam_from_target.inverse();
    let centre = Vector3::new(0.0, 0.0, 0.5);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut st = Stats {
        eligible: 0,
        recalled: 0,
        false_dots: 0,
        centroid_err: Vec::new(),
        projected_err: Vec::new(),
        eligible_err: Vec::new(),
        corrected_err: Vec::new(),
    };
    for _ in 0..views {
        let orbit = UnitQuaternion::from_euler_angles(0.0, rng.random_range(-0.17..0.17), rng.random_range(-0.26..0.26));
        let about_centre = Translation3::from(centre) * Isometry3::from_parts(Translation3::identity(), orbit) * Translation3::from(-centre);
        let mut scene = base.clone();
        scene.cam_from_target = (about_centre * world_from_cam0).inverse();
        if shift_m > 0.0 {
            let shift = Vector3::new(rng.random_range(-shift_m..shift_m), rng.random_range(-shift_m..shift_m), 0.0);
            scene.cam_from_target = Translation3::from(shift) * scene.cam_from_target;
        }
        scene.camera.lens = synthcam::camera::Lens::OpenCv(Distortion::from_array(dist));
        scene.render.noise_sigma = 1.0;
        scene.render.seed = rng.random();
        if let Target::SPath(s) = &mut scene.target {
            s.style = style;
        }
        let img = renderer().render(&scene).expect("render");
        let (w, h) = (scene.camera.size.width as usize, scene.camera.size.height as usize);
        let img = ImageF32::from_u8(w, h, &img.to_u8()).expect("image");
        let truth = truth_labels(&scene);
        let det = detect(&img, &TargetSpec::SPath { points: 101 }).expect("detect");
        if let Ok(v) = std::env::var("NEAR") {
            let v: Vec<f64> = v.split(',').map(|t| t.parse().expect("num")).collect();
            for d in synthcam::detect::dots::find_dots(&img, &synthcam::detect::dots::DotParams::default()).expect("dots") {
                if (d.centre_px.x - v[0]).abs() < 40.0 && (d.centre_px.y - v[1]).abs() < 40.0 {
                    let idx = det.points_px.iter().position(|p| *p == d.centre_px).map(|k| det.indices.as_ref().map(|i| i[k]));
                    eprintln!("near: {:.1},{:.1} area {:.1} core {} index {idx:?}", d.centre_px.x, d.centre_px.y, d.area_px, d.core_px);
                }
            }
            for f in truth.features.iter().filter(|f| f.visible && (f.pixel_px[0] - v[0]).abs() < 40.0 && (f.pixel_px[1] - v[1]).abs() < 40.0) {
                eprintln!("truth {}: centroid {:?} area {:?}", f.id, f.centroid_px, f.area_px);
            }
        }
        if std::env::var("DUMP").is_ok() {
            let k = st.eligible;
            eprintln!("view at eligible {k}: found {} dots, note {:?}", det.points_px.len(), det.note);
            image::GrayImage::from_raw(w as u32, h as u32, img.data.iter().map(|v| *v as u8).collect())
                .expect("img")
                .save(format!("/tmp/pv_{k}.png"))
                .expect("save");
        }
        let indices = det.indices.clone().unwrap_or_default();
        for f in &truth.features {
            let big = f.area_px.is_some_and(|a| a >= std::f64::consts::PI * 1.5 * 1.5);
            if f.visible && big {
                st.eligible += 1;
                if std::env::var("MISSED").is_ok() && !indices.contains(&f.id) {
                    eprintln!(
                        "missed dot {} area {:.1} at {:?} (found {} dots, note {:?})",
                        f.id,
                        f.area_px.unwrap_or(0.0),
                        f.pixel_px,
                        det.points_px.len(),
                        det.note
                    );
                }
            }
        }
        if indices.len() >= 6 {
            let dots = Dots { ids: indices.clone(), pixels_px: det.points_px.clone() };
            if let Ok((_, used)) = pose_from_dots(&scene, &dots, 2) {
                st.corrected_err.extend(used.iter().zip(&indices).map(|(q, i)| (q - Point2::from(truth.features[*i].pixel_px)).norm()));
            }
        }
        for (p, i) in det.points_px.iter().zip(&indices) {
            let f = &truth.features[*i];
            let Some(c) = f.centroid_px else {
                st.false_dots += 1;
                continue;
            };
            let e = (p - Point2::from(c)).norm();
            if e > 1.0 {
                if std::env::var("MISSED").is_ok() {
                    eprintln!("false dot: index {i} at {p} is {e:.2} px from its truth centroid (area {:?})", f.area_px);
                }
                st.false_dots += 1;
                continue;
            }
            if f.area_px.is_some_and(|a| a >= std::f64::consts::PI * 1.5 * 1.5) {
                st.recalled += 1;
                st.eligible_err.push(e);
            }
            st.centroid_err.push(e);
            st.projected_err.push((p - Point2::from(f.pixel_px)).norm());
        }
    }
    st
}

fn summary(name: &str, st: &Stats) -> (f64, f64, f64) {
    let rms = |v: &[f64]| (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    let mut sorted = st.centroid_err.clone();
    sorted.sort_by(f64::total_cmp);
    let p99 = sorted.get(sorted.len() * 99 / 100).copied().unwrap_or(0.0);
    eprintln!(
        "{name}: recall {}/{} ({:.1} %), false dots {}, vs centroid RMS {:.4} p99 {:.4} max {:.4} px (radius >= 1.5 px: RMS {:.4} max {:.4}), vs projected centre RMS {:.4} max {:.4} px, after the bias correction RMS {:.4} max {:.4} px",
        st.recalled,
        st.eligible,
        100.0 * st.recalled as f64 / st.eligible.max(1) as f64,
        st.false_dots,
        rms(&st.centroid_err),
        p99,
        max(&st.centroid_err),
        rms(&st.eligible_err),
        max(&st.eligible_err),
        rms(&st.projected_err),
        max(&st.projected_err),
        rms(&st.corrected_err),
        max(&st.corrected_err)
    );
    (st.recalled as f64 / st.eligible.max(1) as f64, rms(&st.centroid_err), max(&st.centroid_err))
}

#[test]
fn s_path_beads_from_course_like_poses() {
    let st = run(DotStyle::Bead, 20, 111);
    let (recall, rms, max) = summary("beads", &st);
    // Issue targets: recall >= 99 %, RMS <= 0.015 px, max <= 0.06 px: met. Measured 2026-11-24
    // (session 4) over 20 views: recall 2015/2020 (99.8 %; the misses: three beads pressed
    // into one blob, which is dropped, not indexed), 0 false, RMS 0.0066 px, p99 0.018, max
    // 0.051 px. The sphere's outline is one conic fitted to every clean crossing in the image
    // (`detect::outline`), and a bead past the sphere's limb (hidden where they overlap) is told
    // from one in front of it. Session 3: RMS 0.0126, max 0.237.
    assert_eq!(st.false_dots, 0);
    assert!(recall >= 0.99, "recall {recall}");
    assert!(rms <= 0.015, "RMS {rms}");
    assert!(max <= 0.06, "max {max}");
}

#[test]
fn s_path_discs_from_course_like_poses() {
    let st = run(DotStyle::Disc, 20, 112);
    let (recall, rms, max) = summary("discs", &st);
    // Painted discs become one-pixel slivers along the sphere's outline; from oblique views the
    // start dot is hidden. The dots are indexed by fitting a projection of the known 3-D path
    // (`detect::s_path_fit`). Measured 2026-11-24 (session 4) over 20 views: recall 1950/1952
    // (99.9 %), 0 false or mis-indexed dots, vs centroid RMS 0.0101 px, p99 0.037, max 0.055
    // px: the targets are met. The last step was the renderer's: its 16 x 16 samples
    // misplaced the sphere's outline next to a sliver by up to 3 % of a pixel (the outline is
    // now in closed form there too; max 0.062 before). Session 3: RMS 0.026, max 0.64 (a
    // mid-grey background patch took a sliver's end; the outline extrapolated from one side;
    // every pixel of the grown window weighed in with its noise).
    assert_eq!(st.false_dots, 0, "mis-indexed or false dots");
    assert!(recall >= 0.99, "recall {recall}");
    assert!(rms <= 0.015, "RMS {rms}");
    assert!(max <= 0.06, "max {max}");
}

/// Partial views (the target shifted up to 0.35 m in the image plane, so that up to half of the S
/// leaves the 1280 x 1024 frame) through a strongly distorting lens (k1 = -0.25, k2 = 0.08): the
/// visible dots keep their path index (a wrong index is counted as a false dot). Measured
/// 2026-11-24: beads recall 665/684 (97.2 %; the misses are beads squeezed into one blob along
/// the outline in a corner, which the detector drops rather than index), discs 662/668 (99.1 %),
/// 0 false or mis-indexed dots; before the 3-D path fit one of these views was not found at all
/// and chains took every other dot.
#[test]
fn s_path_partial_views_under_distortion_keep_their_indices() {
    for (style, name, seed) in [(DotStyle::Bead, "beads, partial + k1 -0.25", 21), (DotStyle::Disc, "discs, partial + k1 -0.25", 22)] {
        let st = run_with(style, 8, seed, [-0.25, 0.08, 0.0, 0.0, 0.0], 0.35);
        let (recall, _, _) = summary(name, &st);
        assert_eq!(st.false_dots, 0, "{name}: mis-indexed or false dots");
        assert!(recall >= 0.95, "{name}: recall {recall}");
    }
}
