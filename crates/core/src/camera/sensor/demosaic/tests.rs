use super::*;
use crate::camera::sensor::{grey_to_rgb, mosaic};

const ALL_METHODS: [Demosaic; 2] = [Demosaic::Bilinear, Demosaic::MalvarHeCutler];

/// Mosaic a grey scene, demosaic it, back to grey: per-pixel error `grey_out - grey_in`.
fn grey_round_trip(grey: &[f32], w: usize, h: usize, p: BayerPattern, m: Demosaic) -> Vec<f32> {
    let raw = mosaic(&grey_to_rgb(grey), w, h, p).unwrap();
    let out = rgb_to_grey(&demosaic(&raw, w, h, p, m).unwrap());
    out.iter().zip(grey).map(|(o, g)| o - g).collect()
}

fn max_and_rms(err: &[f32]) -> (f32, f32) {
    let max = err.iter().fold(0.0f32, |a, e| a.max(e.abs()));
    let rms = (err.iter().map(|e| f64::from(e * e)).sum::<f64>() / err.len() as f64).sqrt() as f32;
    (max, rms)
}

#[test]
fn constant_image_is_exact() {
    let (w, h) = (9, 7);
    for p in BayerPattern::ALL {
        for m in ALL_METHODS {
            let raw = vec![137.25f32; w * h];
            let rgb = demosaic(&raw, w, h, p, m).unwrap();
            assert!(rgb.iter().flatten().all(|v| (v - 137.25).abs() < 1e-4), "{p} {m:?}");
        }
    }
}

/// Output of a single impulse of 8 (so the outputs are the paper's coefficients in units of
/// 1/8) at pixel `q` of a 13 x 13 RGGB image, compared with every pixel of `want`
/// (others must be 0).
fn check_impulse(method: Demosaic, q: (usize, usize), want: &[((usize, usize), [f32; 3])]) {
    let (w, h) = (13, 13);
    let mut raw = vec![0.0f32; w * h];
    raw[q.1 * w + q.0] = 8.0;
    let rgb = demosaic(&raw, w, h, BayerPattern::Rggb, method).unwrap();
    for (i, px) in rgb.iter().enumerate() {
        let at = (i % w, i / w);
        let expect = want.iter().find(|(p, _)| *p == at).map_or([0.0; 3], |(_, v)| *v);
        assert_eq!(*px, expect, "{method:?}, impulse at {q:?}, pixel {at:?}");
    }
}

/// Hand-evaluated from Malvar, He, Cutler 2004 Fig. 2: an impulse at pixel q reaches pixel p
/// with the weight the filter used at p puts on offset q - p.
#[test]
fn malvar_impulse_response_is_the_papers_kernels() {
    // Red impulse at (6, 6): R centre; G at R (centre 4, -1 at distance 2); B at R (centre 6,
    // -3/2 at distance 2); R at G (4 at distance 1); R at B (2 on the diagonal).
    let red: Vec<((usize, usize), [f32; 3])> = vec![
        ((6, 6), [8.0, 4.0, 6.0]),
        ((5, 6), [4.0, 0.0, 0.0]),
        ((7, 6), [4.0, 0.0, 0.0]),
        ((6, 5), [4.0, 0.0, 0.0]),
        ((6, 7), [4.0, 0.0, 0.0]),
        ((5, 5), [2.0, 0.0, 0.0]),
        ((7, 5), [2.0, 0.0, 0.0]),
        ((5, 7), [2.0, 0.0, 0.0]),
        ((7, 7), [2.0, 0.0, 0.0]),
        ((4, 6), [0.0, -1.0, -1.5]),
        ((8, 6), [0.0, -1.0, -1.5]),
        ((6, 4), [0.0, -1.0, -1.5]),
        ((6, 8), [0.0, -1.0, -1.5]),
    ];
    check_impulse(Demosaic::MalvarHeCutler, (6, 6), &red);
    // Green impulse at (7, 6) (green in a red row): R and B centre 5; G at R/B 2 at distance 1;
    // -1 on the diagonals; at +-2 along the row R gets -1, B gets 1/2; along the column the reverse.
    let green: Vec<((usize, usize), [f32; 3])> = vec![
        ((7, 6), [5.0, 8.0, 5.0]),
        ((6, 6), [0.0, 2.0, 0.0]),
        ((8, 6), [0.0, 2.0, 0.0]),
        ((7, 5), [0.0, 2.0, 0.0]),
        ((7, 7), [0.0, 2.0, 0.0]),
        ((6, 5), [-1.0, 0.0, -1.0]),
        ((8, 5), [-1.0, 0.0, -1.0]),
        ((6, 7), [-1.0, 0.0, -1.0]),
        ((8, 7), [-1.0, 0.0, -1.0]),
        ((5, 6), [-1.0, 0.0, 0.5]),
        ((9, 6), [-1.0, 0.0, 0.5]),
        ((7, 4), [0.5, 0.0, -1.0]),
        ((7, 8), [0.5, 0.0, -1.0]),
    ];
    check_impulse(Demosaic::MalvarHeCutler, (7, 6), &green);
}

#[test]
fn bilinear_impulse_response() {
    let red: Vec<((usize, usize), [f32; 3])> = vec![
        ((6, 6), [8.0, 0.0, 0.0]),
        ((5, 6), [4.0, 0.0, 0.0]),
        ((7, 6), [4.0, 0.0, 0.0]),
        ((6, 5), [4.0, 0.0, 0.0]),
        ((6, 7), [4.0, 0.0, 0.0]),
        ((5, 5), [2.0, 0.0, 0.0]),
        ((7, 5), [2.0, 0.0, 0.0]),
        ((5, 7), [2.0, 0.0, 0.0]),
        ((7, 7), [2.0, 0.0, 0.0]),
    ];
    check_impulse(Demosaic::Bilinear, (6, 6), &red);
}

#[test]
fn borders_mirror_without_repeating_the_edge() {
    assert_eq!([-2, -1, 0, 4, 5, 6].map(|i| reflect(i, 5)), [2, 1, 0, 4, 3, 2]);
    assert_eq!([-2, -1, 2, 3].map(|i| reflect(i, 2)), [0, 1, 0, 1]);
    assert_eq!(reflect(-7, 1), 0);
    // A horizontal ramp is reproduced by bilinear G at the left border only if the mirror keeps
    // colours: pixel (0, 0) of RGGB is red, its G estimate averages (1, 0) twice and (0, 1) twice.
    let (w, h) = (6, 4);
    let raw: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 * 10.0 + (i / w) as f32).collect();
    let rgb = demosaic(&raw, w, h, BayerPattern::Rggb, Demosaic::Bilinear).unwrap();
    assert_eq!(rgb[0], [0.0, (10.0 + 10.0 + 1.0 + 1.0) / 4.0, 11.0]);
    for m in ALL_METHODS {
        for (w, h) in [(1, 1), (1, 5), (2, 1), (3, 2)] {
            assert_eq!(demosaic(&vec![1.0; w * h], w, h, BayerPattern::Gbrg, m).unwrap().len(), w * h);
        }
        assert_eq!(demosaic(&[], 0, 3, BayerPattern::Rggb, m), Ok(vec![]));
    }
}

/// Slanted (10 deg) step 20 -> 220 with a 1-pixel linear ramp (box-filtered edge).
fn slanted_step(w: usize, h: usize) -> Vec<f32> {
    let (c, s) = (10f32.to_radians().cos(), 10f32.to_radians().sin());
    let (cx, cy) = (w as f32 / 2.0 - 0.3, h as f32 / 2.0);
    (0..w * h)
        .map(|i| {
            let d = ((i % w) as f32 - cx) * c + ((i / w) as f32 - cy) * s;
            20.0 + 200.0 * (d + 0.5).clamp(0.0, 1.0)
        })
        .collect()
}

/// `128 + 100 sin(2 pi d / 16)` along a direction 30 deg from the x axis.
fn slanted_sinusoid(w: usize, h: usize) -> Vec<f32> {
    let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    (0..w * h).map(|i| 128.0 + 100.0 * (std::f32::consts::TAU * ((i % w) as f32 * c + (i / w) as f32 * s) / 16.0).sin()).collect()
}

#[test]
fn grey_scene_errors_are_within_the_documented_bounds() {
    let (w, h) = (96, 96);
    let step = slanted_step(w, h);
    let sine = slanted_sinusoid(w, h);
    let cases = [
        ("step", &step, Demosaic::Bilinear, TOL_STEP_BI),
        ("step", &step, Demosaic::MalvarHeCutler, TOL_STEP_MHC),
        ("sine", &sine, Demosaic::Bilinear, TOL_SIN_BI),
        ("sine", &sine, Demosaic::MalvarHeCutler, TOL_SIN_MHC),
    ];
    for (name, img, m, (max_tol, rms_tol)) in cases {
        for p in BayerPattern::ALL {
            let (max, rms) = max_and_rms(&grey_round_trip(img, w, h, p, m));
            println!("{name} {m:?} {p}: max {max:.3}, RMS {rms:.3} grey levels");
            assert!(max <= max_tol && rms <= rms_tol, "{name} {m:?} {p}: max {max}, RMS {rms}");
        }
    }
}

/// (max, RMS) bounds: the measured worst case over the patterns (doc of [`Demosaic`]) + ~10 %.
const TOL_STEP_BI: (f32, f32) = (68.0, 4.5);
const TOL_STEP_MHC: (f32, f32) = (32.0, 2.4);
const TOL_SIN_BI: (f32, f32) = (34.0, 2.9);
const TOL_SIN_MHC: (f32, f32) = (14.0, 1.8);

#[test]
fn step_is_exact_away_from_the_edge() {
    let (w, h) = (96, 96);
    let step = slanted_step(w, h);
    for m in ALL_METHODS {
        let err = grey_round_trip(&step, w, h, BayerPattern::Rggb, m);
        // Pixels whose 5 x 5 neighbourhood is flat.
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let flat = (0..25).all(|k| step[(y + k / 5 - 2) * w + x + k % 5 - 2] == step[y * w + x]);
                if flat {
                    assert!(err[y * w + x].abs() < 1e-4, "{m:?} at ({x}, {y}): {}", err[y * w + x]);
                }
            }
        }
    }
}

#[test]
fn from_str_and_sizes() {
    assert_eq!("bilinear".parse(), Ok(Demosaic::Bilinear));
    assert_eq!("Malvar".parse(), Ok(Demosaic::MalvarHeCutler));
    assert_eq!("malvar-he-cutler".parse(), Ok(Demosaic::MalvarHeCutler));
    assert_eq!(Demosaic::MalvarHeCutler.name().parse(), Ok(Demosaic::MalvarHeCutler));
    let err = "ahd".parse::<Demosaic>().unwrap_err();
    assert!(matches!(&err, SensorError::InvalidField { field: "output.demosaic", .. }));
    assert!(err.to_string().contains("`ahd`"), "{err}");
    assert!(matches!(demosaic(&[0.0; 5], 2, 3, BayerPattern::Rggb, Demosaic::Bilinear), Err(SensorError::Size { got: 5, width: 2, height: 3 })));
    assert_eq!(rgb_to_grey(&[[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 100.0]]), vec![29.9, 58.7, 11.4]);
}
