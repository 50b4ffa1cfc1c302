//! The sensor and output effects (issue 18) on rendered images: the EMVA 1288 photon transfer
//! and non-uniformity measurements on rendered flat fields, Bayer raw and demosaiced RGB output,
//! and bad effect tables.

use nalgebra::{Isometry3, Point2, Translation3, UnitQuaternion};
use synthcam::camera::sensor::SensorModel;
use synthcam::render::GreyImage;
use synthcam::scene::effects::PixelFormat;
use synthcam::scene::file::parse_scene;
use synthcam::scene::truth::truth_labels;
use synthcam::scene::Scene;
use synthcam::target::{Chessboard, Target};

use crate::camera_effects::detect;
use crate::chessboard_accuracy::{nn_errors, rms};
use crate::common::{bin, camera, renderer};

/// A 640 x 512 camera whose whole view is the background at grey `level` (the board is far to
/// the side), through `sensor`; 16-bit output holds the DN left-justified.
fn flat_field(level: f64, sensor: SensorModel, seed: u64) -> Scene {
    let board = Chessboard { background: level, ..Default::default() };
    let mut s = Scene {
        camera: camera(640, 512, 600.0, [0.0; 5]),
        target: Target::Chessboard(board),
        cam_from_target: Isometry3::from_parts(Translation3::new(50.0, 0.0, 1.0), UnitQuaternion::identity()),
        render: Default::default(),
        objects: Vec::new(),
        background: None,
    };
    s.render.effects.sensor = Some(sensor);
    s.render.bit_depth = 16;
    s.render.seed = seed;
    s
}

fn dn(scene: &Scene) -> Vec<f64> {
    let Some(model) = scene.render.effects.sensor else { panic!("sensor") };
    match renderer().render(scene).expect("render") {
        GreyImage::U16(i) => i.as_raw().iter().map(|v| f64::from(v >> (16 - model.bit_depth))).collect(),
        _ => panic!("16-bit output expected"),
    }
}

fn mean_var(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (m, v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64)
}

/// EMVA 1288 sec. 6.2: mean of a frame pair, temporal variance var(A - B) / 2.
fn pair_stats(level: f64, sensor: SensorModel) -> (f64, f64) {
    let (a, b) = (dn(&flat_field(level, sensor, 1)), dn(&flat_field(level, sensor, 2)));
    let mean = 0.5 * (mean_var(&a).0 + mean_var(&b).0);
    let diff: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x - y).collect();
    (mean, 0.5 * mean_var(&diff).1)
}

fn test_sensor() -> SensorModel {
    SensorModel {
        photons_per_s_at_255: 2.5e6,
        quantum_efficiency: 0.6,
        full_well_e: 20_000.0,
        dark_current_e_per_s: 5.0,
        read_noise_e: 5.0,
        prnu: 0.02,
        dsnu_e: 3.0,
        gain_dn_per_e: 0.1,
        bit_depth: 12,
        black_level_dn: 10.0,
        ..SensorModel::default()
    }
}

#[test]
fn photon_transfer_of_rendered_flat_fields_recovers_gain_and_read_noise() {
    let sensor = test_sensor();
    // Exposure series up to ~60 % of the full well at grey 200 (EMVA fits below 70 %).
    let (mut sxy, mut sxx) = (0.0, 0.0);
    let mut dark0 = (0.0, 0.0);
    for k in 1..=12 {
        let s = SensorModel { exposure_s: 0.01 * f64::from(k) / 12.0, ..sensor };
        let (mu, var) = pair_stats(200.0, s);
        let (mu_d, var_d) = pair_stats(0.0, s);
        if k == 1 {
            dark0 = (mu_d, var_d);
        }
        sxy += (mu - mu_d) * (var - var_d);
        sxx += (mu - mu_d).powi(2);
    }
    let k_fit = sxy / sxx;
    // sigma_y.dark^2 = K^2 (sigma_d^2 + mu_e.dark) + 1/12; dark electrons at 0.83 ms are 0.004.
    let read_e = ((dark0.1 - 1.0 / 12.0) / (k_fit * k_fit)).sqrt();
    let (ek, er) = (k_fit / sensor.gain_dn_per_e - 1.0, read_e / sensor.read_noise_e - 1.0);
    eprintln!(
        "EMVA photon transfer (12 exposures, rendered 640x512 flat-field pairs): K {k_fit:.5} DN/e ({:+.2} %), read noise {read_e:.3} e ({:+.2} %)",
        100.0 * ek,
        100.0 * er
    );
    assert!(ek.abs() <= 0.02 && er.abs() <= 0.05);
}

#[test]
fn prnu_and_dsnu_of_averaged_rendered_frames_match_the_settings() {
    let sensor = SensorModel { exposure_s: 0.005, ..test_sensor() };
    let l = 16;
    let average = |level: f64| -> (Vec<f64>, f64) {
        let frames: Vec<Vec<f64>> = (0..l).map(|s| dn(&flat_field(level, sensor, 100 + s))).collect();
        let avg: Vec<f64> = (0..frames[0].len()).map(|i| frames.iter().map(|f| f[i]).sum::<f64>() / l as f64).collect();
        // Temporal variance left in the average: the per-pixel frame variance / L.
        let temporal =
            (0..frames[0].len()).map(|i| frames.iter().map(|f| (f[i] - avg[i]).powi(2)).sum::<f64>() / (l - 1) as f64).sum::<f64>() / avg.len() as f64;
        (avg, temporal / l as f64)
    };
    let ((dark, t_dark), (bright, t_bright)) = (average(0.0), average(200.0));
    let (mu_dark, s_dark) = mean_var(&dark);
    let (mu_50, s_50) = mean_var(&bright);
    let (s_dark, s_50) = (s_dark - t_dark, s_50 - t_bright);
    let dsnu_e = s_dark.sqrt() / sensor.gain_dn_per_e;
    let prnu = (s_50 - s_dark).sqrt() / (mu_50 - mu_dark);
    let (ed, ep) = (dsnu_e / sensor.dsnu_e - 1.0, prnu / sensor.prnu - 1.0);
    eprintln!(
        "EMVA non-uniformity (16 averaged rendered frames): DSNU {dsnu_e:.3} e ({:+.2} %), PRNU {:.4} % ({:+.2} %) at {:.0} % of the full well",
        100.0 * ed,
        100.0 * prnu,
        100.0 * ep,
        100.0 * (mu_50 - mu_dark) / sensor.gain_dn_per_e / sensor.full_well_e
    );
    assert!(ed.abs() <= 0.05 && ep.abs() <= 0.05);
}

#[test]
fn demosaiced_renders_match_the_grey_render_and_the_detector_runs_on_raw_and_rgb() {
    let grey = parse_scene(include_str!("../../assets/scenes/chessboard_k1.toml")).expect("scene");
    let g = grey.clone();
    let grey_img = renderer().render(&g).expect("render").to_u8();
    let truth: Vec<Point2<f64>> = truth_labels(&grey).features.iter().map(|f| Point2::from(f.pixel_px)).collect();
    // The documented bounds (`Demosaic`): bilinear stays within the 3 x 3 neighbourhood's range,
    // Malvar-He-Cutler within 1.875 times the 5 x 5 neighbourhood's; + 1 for the quantisation of
    // the channels and of the luma.
    let (w, h) = (1280usize, 1024usize);
    let range = |x: usize, y: usize, r: usize| -> f64 {
        let (mut lo, mut hi) = (255u8, 0u8);
        for yy in y.saturating_sub(r)..=(y + r).min(h - 1) {
            for xx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                lo = lo.min(grey_img[yy * w + xx]);
                hi = hi.max(grey_img[yy * w + xx]);
            }
        }
        f64::from(hi - lo)
    };
    for (name, reach, factor, format, method) in [
        ("bilinear", 1, 1.0, PixelFormat::Rgb(synthcam::camera::sensor::BayerPattern::Rggb), synthcam::camera::sensor::Demosaic::Bilinear),
        ("Malvar-He-Cutler", 2, 1.875, PixelFormat::Rgb(synthcam::camera::sensor::BayerPattern::Grbg), synthcam::camera::sensor::Demosaic::MalvarHeCutler),
    ] {
        let mut s = grey.clone();
        s.render.effects.output.format = format;
        s.render.effects.output.demosaic = method;
        let img = renderer().render(&s).expect("render");
        assert!(matches!(img, GreyImage::Rgb8(_)));
        let luma = img.to_u8();
        let d: Vec<f64> = luma.iter().zip(&grey_img).map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs()).collect();
        let max = d.iter().cloned().fold(0.0, f64::max);
        let outside = d.iter().enumerate().filter(|(i, e)| **e > factor * range(i % w, i / w, reach) + 1.0).count();
        let e = nn_errors(&detect(&img, [11, 8]), &truth);
        eprintln!("demosaic {name}: luma vs the grey render max {max:.0}, RMS {:.3} grey levels, {outside} pixels beyond the documented bound; corners on the RGB image vs truth RMS {:.4} px, max {:.4} px", rms(&d), rms(&e), e.iter().cloned().fold(0.0, f64::max));
        assert_eq!(outside, 0);
        assert!(rms(&e) <= 0.1 && e.iter().all(|x| *x <= 0.3), "corners {e:?}");
    }
    let mut raw = grey.clone();
    raw.render.effects.output.format = PixelFormat::Bayer(synthcam::camera::sensor::BayerPattern::Bggr);
    raw.render.effects.sensor = Some(SensorModel { exposure_s: 0.01, photons_per_s_at_255: 1.5e6, ..SensorModel::default() });
    let img = renderer().render(&raw).expect("render");
    let e = nn_errors(&detect(&img, [11, 8]), &truth);
    eprintln!("Bayer raw (BGGR, EMVA default sensor, 8-bit): corners vs truth RMS {:.4} px, max {:.4} px", rms(&e), e.iter().cloned().fold(0.0, f64::max));
    assert!(rms(&e) <= 0.05 && e.iter().all(|x| *x <= 0.1), "corners {e:?}");
}

#[test]
fn bad_effect_tables_are_rejected_naming_the_field() {
    let base = include_str!("../../assets/scenes/chessboard_k1.toml");
    for (table, field) in [
        ("[sensor]\nexposure_s = -0.01\n", "sensor.exposure_s"),
        ("[sensor]\nfull_well_e = 2.0\nread_noise_e = 3.0\n", "sensor.full_well_e"),
        ("[sensor]\nbit_depth = 9\n", "sensor.bit_depth"),
        ("[output]\nformat = \"bayer-rgbx\"\n", "output.format"),
        ("[output]\ndemosaic = \"nearest\"\n", "output.demosaic"),
        ("[output]\njpeg_quality = 0\n", "output.jpeg_quality"),
        ("[optics]\nf_number = 2.0\n", "optics.f_number"),
        ("[optics]\nf_number = -2.0\nfocal_length_m = 0.01\nfocus_distance_m = 1.0\n", "optics.f_number"),
        ("[optics]\nvignetting = [0.1, 0.2, 0.3, 0.4]\n", "optics.vignetting"),
        ("[motion]\nline_delay_s = -1e-5\n", "motion.line_delay_s"),
        ("[motion]\ntwist = [0, 0, 0, nan, 0, 0]\n", "motion.twist"),
        ("[motion]\nreadout = \"sideways\"\n", "readout"),
    ] {
        let text = format!("{base}\n{table}");
        let err = parse_scene(&text).expect_err(table).to_string();
        assert!(err.contains(field), "{table}: {err}");
    }
    let dir = std::env::temp_dir().join(format!("synthcam-bad-effects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("bad.toml");
    std::fs::write(&path, format!("{base}\n[sensor]\nbit_depth = 9\n")).expect("write");
    let out = std::process::Command::new(bin()).args(["render", path.to_str().expect("path"), "-o"]).arg(dir.join("x.png")).output().expect("run");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("sensor.bit_depth"), "{stderr}");
    assert!(!dir.join("x.png").exists(), "no half-written output");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn vignetting_follows_cos4_and_the_radial_polynomial() {
    // A flat field at grey 200 through cos^4 fall-off and 1 - 0.3 r^2 + 0.05 r^4, 16-bit output
    // (no sensor, no noise): each pixel against the closed form for a pinhole, cos(theta) =
    // f / sqrt(f^2 + d^2), d the pixel's distance from the principal point.
    let mut s = flat_field(200.0, SensorModel::default(), 0);
    s.render.effects.sensor = None;
    s.render.effects.optics = synthcam::camera::optics::Optics { natural_falloff: true, vignetting: [-0.3, 0.05, 0.0], ..Default::default() };
    let GreyImage::U16(img) = renderer().render(&s).expect("render") else { panic!("16-bit") };
    let (f, cx, cy) = (600.0f64, s.camera.intrinsics.cx, s.camera.intrinsics.cy);
    let half_diag = 0.5 * 640f64.hypot(512.0);
    let mut worst: f64 = 0.0;
    for (x, y, p) in img.enumerate_pixels() {
        let d = (f64::from(x) - cx).hypot(f64::from(y) - cy);
        let cos = f / f.hypot(d);
        let r2 = (d / half_diag).powi(2);
        let expect = 200.0 * cos.powi(4) * (1.0 - 0.3 * r2 + 0.05 * r2 * r2);
        worst = worst.max((f64::from(p.0[0]) / 257.0 - expect).abs());
    }
    eprintln!("vignetting: rendered flat field vs cos^4 x polynomial, max |diff| {worst:.4} grey levels (16-bit quantisation: 0.002)");
    assert!(worst < 0.003, "{worst}");
}

#[test]
fn colour_targets_render_per_channel_albedo_through_the_colour_filter_array() {
    // 8 x 6 squares of 60 px, fronto-parallel: square (i, j) spans x 100 + 60 i .. , y 60 + 60 j.
    let mut s = crate::common::chessboard_scene(camera(640, 480, 600.0, [0.0; 5]), [8, 6], 0.1, 0.0, 1.0, [0.0, 0.0]);
    let rgb = [[200.0, 30.0, 30.0], [30.0, 200.0, 60.0], [30.0, 200.0, 60.0], [90.0, 90.0, 200.0]];
    s.render.effects.output.target_rgb = Some(rgb);
    let colour_at = |x: f64, y: f64| -> [f64; 3] {
        let p = s.cam_from_target.inverse() * nalgebra::Point3::new((x - 319.5) / 600.0, (y - 239.5) / 600.0, 1.0);
        let o = s.cam_from_target.inverse() * nalgebra::Point3::origin();
        let t = -o.z / (p.z - o.z);
        let (bx, by) = (o.x + t * (p.x - o.x), o.y + t * (p.y - o.y));
        let dark = s.target.plane_intensity(bx, by).expect("on the board") < 100.0;
        if dark {
            rgb[0]
        } else {
            rgb[1]
        }
    };
    for (pattern, name) in [(synthcam::camera::sensor::BayerPattern::Rggb, "rggb"), (synthcam::camera::sensor::BayerPattern::Gbrg, "gbrg")] {
        s.render.effects.output.format = PixelFormat::Bayer(pattern);
        let GreyImage::U8(raw) = renderer().render(&s).expect("render") else { panic!("raw is one channel") };
        s.render.effects.output.format = PixelFormat::Rgb(pattern);
        let GreyImage::Rgb8(img) = renderer().render(&s).expect("render") else { panic!("RGB") };
        let (mut checked, mut worst) = (0, 0.0f64);
        // Square centres, 25 px from every edge: flat for the raw image and for the demosaicer.
        for j in 0..6 {
            for i in 0..8 {
                let (cx, cy) = (320.0 - 240.0 + 60.0 * f64::from(i) + 30.0, 240.0 - 180.0 + 60.0 * f64::from(j) + 30.0);
                let want = colour_at(cx, cy);
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let (x, y) = (cx as u32 + dx, cy as u32 + dy);
                    let c = pattern.channel_at(x as usize, y as usize);
                    worst = worst.max((f64::from(raw.get_pixel(x, y).0[0]) - want[c]).abs());
                    let p = img.get_pixel(x, y).0;
                    worst = worst.max((0..3).map(|k| (f64::from(p[k]) - want[k]).abs()).fold(0.0, f64::max));
                    checked += 1;
                }
            }
        }
        eprintln!("colour target, {name}: raw and demosaiced RGB inside the squares vs the albedo, max |diff| {worst} over {checked} pixels");
        assert!(worst <= 0.5, "{name}: {worst}");
    }
}
