//! Dot-grid detection on renders: the course's grid (5 x 5 and 9 x 9 dots over 0.4 m) seen from
//! the course's calibration poses (3-6 m, tilt <= 18 degrees), course camera, noise 1 grey level.

use nalgebra::{Isometry3, Point2, Translation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use synthcam::camera::CameraModel;
use synthcam::detect::target::{detect, TargetSpec};
use synthcam::detect::ImageF32;
use synthcam::scene::truth::truth_labels;
use synthcam::scene::{RenderSettings, Scene};
use synthcam::target::{DotGrid, Target};

use crate::common::renderer;

#[test]
fn course_dot_grids_are_found_in_grid_order() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for n in [5u32, 9] {
        let (mut found, mut errs, views) = (0, Vec::new(), 10);
        for v in 0..views {
            let grid = DotGrid { n, edge_m: 0.4, dot_radius_m: 0.2 * 0.4 / f64::from(n - 1), margin_m: 0.5 * 0.4 / f64::from(n - 1), ..Default::default() };
            // Course pose sampling: rotation <= 18 deg about a random axis, camera 3-6 m away.
            let axis = nalgebra::Unit::new_normalize(Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)));
            let rot = UnitQuaternion::from_axis_angle(&axis, rng.random_range(0.0..0.1 * std::f64::consts::PI));
            let t = Vector3::new(rng.random_range(-0.15..0.15), rng.random_range(-0.15..0.15), rng.random_range(3.0..6.0));
            let scene = Scene {
                camera: CameraModel::sxga_1500px(),
                target: Target::DotGrid(grid),
                cam_from_target: Isometry3::from_parts(Translation3::from(t), rot),
                render: RenderSettings { noise_sigma: 1.0, seed: v, ..Default::default() },
                objects: Vec::new(),
                background: None,
            };
            let img = renderer().render(&scene).expect("render");
            let img = ImageF32::from_u8(1280, 1024, &img.to_u8()).expect("image");
            let truth = truth_labels(&scene);
            let det = detect(&img, &TargetSpec::DotGrid { n: n as usize }).expect("detect");
            if !det.found {
                continue;
            }
            found += 1;
            // A plain grid has no marker: the detector's order is the truth order up to one of the
            // grid's 8 symmetries (4 rotations, mirrored or not), the same for every dot.
            let centroids: Vec<Point2<f64>> = truth.features.iter().map(|f| Point2::from(f.centroid_px.expect("centroid"))).collect();
            let best = symmetries(n as usize)
                .into_iter()
                .map(|perm| perm.iter().zip(&det.points_px).map(|(t, p)| (p - centroids[*t]).norm()).collect::<Vec<f64>>())
                .min_by(|a, b| a.iter().cloned().fold(0.0, f64::max).total_cmp(&b.iter().cloned().fold(0.0, f64::max)))
                .expect("8 symmetries");
            assert_eq!(best.len(), centroids.len(), "{n}x{n} view {v}: {} dots for {}", det.points_px.len(), centroids.len());
            let worst = best.iter().cloned().fold(0.0, f64::max);
            assert!(worst < 0.2, "{n}x{n} view {v}: no grid symmetry maps the detected order onto the truth (closest max {worst} px)");
            // The documented image rule: dot 0 is the corner nearest the image's top-left (min u + v).
            let corners = [0, n as usize - 1, (n * n - n) as usize, (n * n - 1) as usize].map(|k| det.points_px[k]);
            assert!(corners.iter().all(|c| det.points_px[0].x + det.points_px[0].y <= c.x + c.y), "{n}x{n} view {v}: dot 0 is not the top-left corner");
            errs.extend(best);
        }
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len().max(1) as f64).sqrt();
        let max = errs.iter().cloned().fold(0.0, f64::max);
        eprintln!("dot grid {n}x{n}: {found}/{views} found, centre vs truth centroid RMS {rms:.4} px, max {max:.4} px");
        assert_eq!(found, views, "{n}x{n}");
        assert!(rms <= 0.03, "{n}x{n}: RMS {rms}");
    }
}

/// The 8 relabellings of an n x n grid (index = ix * n + iy): rotations and mirrors of (ix, iy).
fn symmetries(n: usize) -> Vec<Vec<usize>> {
    let m = n - 1;
    type Map = fn(usize, usize, usize) -> (usize, usize);
    let maps: [Map; 8] = [
        |_, i, j| (i, j),
        |m, i, j| (m - j, i),
        |m, i, j| (m - i, m - j),
        |m, i, j| (j, m - i),
        |_, i, j| (j, i),
        |m, i, j| (m - i, j),
        |m, i, j| (m - j, m - i),
        |m, i, j| (i, m - j),
    ];
    maps.iter().map(|f| (0..n * n).map(|k| f(m, k / n, k % n)).map(|(i, j)| i * n + j).collect()).collect()
}
