//! Detector robustness: 10 000 random or corrupted images through every target kind (coded boards
//! included), no panic;
//! "not found" where there is nothing to find.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;

fn random_image(rng: &mut ChaCha8Rng, k: usize) -> ImageF32 {
    let (w, h) = match k % 10 {
        0 => (1, 1),
        1 => (rng.random_range(500..3000), rng.random_range(1..4)),
        2 => (rng.random_range(1..4), rng.random_range(500..3000)),
        _ => (rng.random_range(2..96), rng.random_range(2..96)),
    };
    let style = rng.random_range(0..5);
    let data = (0..w * h)
        .map(|i| match style {
            0 => 128.0,
            1 => rng.random_range(0.0..255.0),
            2 => {
                if (i % w.max(1)) / 7 % 2 == 0 {
                    20.0
                } else {
                    230.0
                }
            }
            3 => {
                if rng.random_bool(0.02) {
                    0.0
                } else {
                    220.0
                }
            }
            _ => f32::from(rng.random_range(0u8..=255)) * 0.5 + ((i % w.max(1)) as f32),
        })
        .collect();
    ImageF32 { width: w, height: h, data }
}

#[test]
fn ten_thousand_random_images_do_not_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let charuco = "charuco:11x8:DICT_4X4_50:0.75".parse::<TargetSpec>().unwrap();
    let aprilgrid = "aprilgrid:5x5:tag16h5:0.3:border_bits=1".parse::<TargetSpec>().unwrap();
    let targets = [TargetSpec::Chessboard { cols: 9, rows: 6 }, TargetSpec::DotGrid { n: 3 }, TargetSpec::SPath { points: 101 }, charuco, aprilgrid];
    let mut found = 0;
    for k in 0..10_000 {
        let img = random_image(&mut rng, k);
        let t = &targets[k % targets.len()];
        match detect(&img, t) {
            Ok(d) => found += usize::from(d.found),
            Err(e) => panic!("image {k}: bad input reported for a valid buffer: {e}"),
        }
    }
    // A 9x6 board, a 3x3 grid, a 101-dot S, two neighbouring markers of the ChArUco board
    // (DICT_4X4_50) or a tag of the AprilGrid (tag16h5 with a 1-bit border: the smallest codes)
    // cannot appear in these images.
    assert_eq!(found, 0);
    // A buffer that does not match its size is an error, not a panic.
    let bad = ImageF32 { width: 10, height: 10, data: vec![0.0; 7] };
    for t in &targets {
        assert!(detect(&bad, t).is_err());
    }
}
