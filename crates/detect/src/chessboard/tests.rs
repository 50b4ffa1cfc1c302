//! Tests of `chessboard`.

use super::*;

/// Area-sampled (4 x 4) board of `sq` px squares, `squares` = (nx, ny), rotated by `angle`
/// about `off`, dark squares where (i + j) is even.
fn board(w: usize, h: usize, sq: f64, squares: (usize, usize), angle: f64, off: (f64, f64)) -> ImageF32 {
    let (s, c) = angle.sin_cos();
    let mut data = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for j in 0..4 {
                for i in 0..4 {
                    let px = x as f64 - 0.5 + (i as f64 + 0.5) / 4.0 - off.0;
                    let py = y as f64 - 0.5 + (j as f64 + 0.5) / 4.0 - off.1;
                    let u = (c * px + s * py) / sq;
                    let v = (-s * px + c * py) / sq;
                    let inside = u >= 0.0 && v >= 0.0 && u < squares.0 as f64 && v < squares.1 as f64;
                    acc += if inside && ((u.floor() + v.floor()) as i64) % 2 == 0 { 25.0 } else { 225.0 };
                }
            }
            data[y * w + x] = acc / 16.0;
        }
    }
    ImageF32 { width: w, height: h, data }
}

#[test]
fn finds_exact_corners_in_documented_order() {
    for angle in [0.15_f64, 0.15 + std::f64::consts::PI, 0.15 + std::f64::consts::FRAC_PI_2] {
        let (sq, off) = (25.0, (200.0, 180.0));
        // rotate about the board centre so every angle stays in the image
        let centre = (off.0, off.1);
        let (s, c) = angle.sin_cos();
        let (hx, hy) = (4.5 * sq, 3.5 * sq);
        let origin = (centre.0 - (c * hx - s * hy), centre.1 - (s * hx + c * hy));
        let img = board(400, 360, sq, (9, 7), angle, origin);
        let b = find_chessboard(&img, &ChessboardParams::new(8, 6)).unwrap().unwrap();
        assert_eq!(b.points_px.len(), 48);
        // truth: corner (i, j) of the board frame, i = 1..8, j = 1..6
        let truth: Vec<Point2<f64>> = (1..7)
            .flat_map(|j| (1..9).map(move |i| (i as f64 * sq, j as f64 * sq)))
            .map(|(u, v)| Point2::new(origin.0 + c * u - s * v, origin.1 + s * u + c * v))
            .collect();
        let worst = b.points_px.iter().map(|p| truth.iter().map(|t| (t - p).norm()).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max);
        assert!(worst < 0.03, "angle {angle}: worst {worst}");
        // ordering rule: rows of 8, handedness kept, first corner nearest the image origin
        let row = b.points_px[7] - b.points_px[0];
        let col = b.points_px[40] - b.points_px[0];
        assert!(row.x * col.y - row.y * col.x > 0.0);
        let first = b.points_px[0].coords.norm();
        let last = b.points_px[47].coords.norm();
        assert!(first < last);
    }
}

#[test]
fn u8_input_gives_the_f32_result() {
    // 640 x 480 has a pyramid level; 200 x 160 is searched at full resolution
    for (w, h, sq, off) in [(640, 480, 40.0, (130.0, 90.0)), (200, 160, 16.0, (25.0, 20.0))] {
        let f = board(w, h, sq, (9, 7), 0.2, off);
        let u = ImageU8::new(w, h, f.data.iter().map(|v| v.round() as u8).collect()).unwrap();
        let p = ChessboardParams::new(8, 6);
        let a = find_chessboard(&u.to_f32(), &p).unwrap().unwrap();
        assert_eq!(find_chessboard_u8(&u, &p).unwrap(), Some(a), "{w}x{h}");
    }
    assert!(find_chessboard_u8(&ImageU8 { width: 9, height: 9, data: vec![0; 80] }, &ChessboardParams::default()).is_err());
}

#[test]
fn transposed_request_gives_rows_of_cols() {
    let img = board(360, 400, 25.0, (7, 9), 0.1, (80.0, 60.0));
    let b = find_chessboard(&img, &ChessboardParams::new(8, 6)).unwrap().unwrap();
    // rows run along the 8-corner direction (here mostly vertical)
    let row = b.points_px[7] - b.points_px[0];
    assert!(row.y.abs() > row.x.abs());
    assert!(find_chessboard(&img, &ChessboardParams::new(7, 6)).unwrap().is_none());
}

/// Over-exposure: the board blurred (sigma 2.5 px) then scaled so the light squares clip at 255
/// with 3x headroom; the dark squares no longer meet at the corners (a light gap blooms over each
/// junction), as on a laminated board under a lamp. Corner truth by symmetry: the blur and the
/// clipping keep each junction point-symmetric, so the corners stay where they were.
fn bloomed(img: &ImageF32, gain: f32) -> ImageF32 {
    let b = super::super::response::gaussian_blur(img, 2.5);
    ImageF32 { width: b.width, height: b.height, data: b.data.iter().map(|v| (v * gain).min(255.0)).collect() }
}

#[test]
fn over_exposed_board_is_found_and_its_corners_are_right() {
    let (sq, off, angle) = (30.0, (60.0, 50.0), 0.12);
    let (s, c) = f64::sin_cos(angle);
    let truth: Vec<Point2<f64>> = (1..6)
        .flat_map(|j| (1..8).map(move |i| (i as f64 * sq, j as f64 * sq)))
        .map(|(u, v)| Point2::new(off.0 + c * u - s * v, off.1 + s * u + c * v))
        .collect();
    let img = bloomed(&board(360, 300, sq, (8, 6), angle, off), 3.0);
    let b = find_chessboard(&img, &ChessboardParams::new(7, 5)).unwrap().expect("the bloomed board is found");
    let trusted: Vec<usize> = (0..b.points_px.len()).filter(|k| !b.untrusted(TRUSTED_CORNER_PX).contains(k)).collect();
    let err = |k: usize| truth.iter().map(|t| (t - b.points_px[k]).norm()).fold(f64::INFINITY, f64::min);
    // every corner is on its junction (no wrong board), and the trusted ones within 0.1 px
    assert!((0..35).all(|k| err(k) < 1.0), "{:?}", (0..35).map(err).collect::<Vec<_>>());
    assert!(trusted.iter().all(|&k| err(k) <= TRUSTED_CORNER_PX), "{:?}", trusted.iter().map(|&k| err(k)).collect::<Vec<_>>());
    // a larger board is not cut down to the size asked for
    assert!(find_chessboard(&img, &ChessboardParams::new(6, 5)).unwrap().is_none());
}

#[test]
fn corners_near_the_image_border_are_searched_and_fitted() {
    // the outer corners 3 px from the left and top borders
    let sq = 24.0;
    let img = board(260, 200, sq, (9, 7), 0.0, (3.0 - sq, 3.0 - sq));
    let b = find_chessboard(&img, &ChessboardParams::new(8, 6)).unwrap().expect("found");
    let worst = (1..7)
        .flat_map(|j| (1..9).map(move |i| Point2::new(3.0 + (i - 1) as f64 * sq, 3.0 + (j - 1) as f64 * sq)))
        .map(|t| b.points_px.iter().map(|p| (t - p).norm()).fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max);
    assert!(worst < 0.05, "worst {worst}");
}

#[test]
fn a_corner_twice_is_not_a_board() {
    let mut b = ChessboardCorners {
        points_px: (0..3).flat_map(|r| (0..4).map(move |c| Point2::new(10.0 * c as f64, 10.0 * r as f64))).collect(),
        cols: 4,
        rows: 3,
        refined: vec![true; 12],
        position_sigma_px: vec![0.01; 12],
        rms_fit_residual: 0.0,
        candidates: 12,
        seeds_tried: 1,
    };
    assert!(even_steps(b.clone()).is_some());
    b.points_px[11] = b.points_px[6]; // the last corner on its diagonal neighbour
    assert!(even_steps(b).is_none());
}

#[test]
fn calibration_leaves_out_failed_fits_and_outliers_only() {
    // a view of uniformly uncertain corners keeps them; a failed fit and a 10x outlier go
    let sigma = [0.06, 0.07, 0.065, f64::INFINITY, 0.7, 0.06];
    let untrusted = [0, 1, 2, 3, 4, 5];
    assert_eq!(corners_to_leave_out(&sigma, &untrusted), vec![3, 4]);
    // only untrusted points are candidates, and a missing sigma counts as a failed fit
    assert_eq!(corners_to_leave_out(&sigma[..3], &[1, 7]), vec![7]);
    assert!(corners_to_leave_out(&[], &[]).is_empty());
}
