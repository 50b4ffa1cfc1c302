//! Tests of `radial`: the division model's parameter recovered from views distorted by its exact
//! inverse, the labelling one index off beyond a split corrected, the significance test, and the
//! assignment's contenders settled by the lens term.

use super::assign::Assignment;
use super::radial::{best_rival, fit, lens_settled, Division};
use super::tests::{dot, jittered, projected};
use super::*;
use rand::{Rng, SeedableRng};

const CENTRE: Point2<f64> = Point2::new(639.5, 511.5);

/// The distorted pixel of the ideal pixel `u` under the division model (the inverse of
/// `Division::undistort`, in closed form: r_u = r_d / (1 + lambda r_d^2) solved for r_d).
fn distort(u: &Point2<f64>, lambda: f64) -> Point2<f64> {
    let d = u - CENTRE;
    let ru = d.norm();
    if lambda == 0.0 || ru == 0.0 {
        return *u;
    }
    let rd = (1.0 - (1.0 - 4.0 * lambda * ru * ru).sqrt()) / (2.0 * lambda * ru);
    CENTRE + d * (rd / ru)
}

/// The course view's visible dots distorted with `lambda`, plus seeded noise of standard
/// deviation `sigma_px` (uniform, per coordinate).
fn distorted_view(lambda: f64, sigma_px: f64, seed: u64) -> (SPath, Vec<Dot>) {
    let (path, pts) = projected();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let half = sigma_px * 3f64.sqrt();
    let mut noise = move || if half > 0.0 { rng.random_range(-half..half) } else { 0.0 };
    let dots = pts
        .iter()
        .map(|p| {
            let q = distort(&p.unwrap(), lambda);
            dot(Point2::new(q.x + noise(), q.y + noise()), 30.0)
        })
        .collect();
    (path, dots)
}

/// Barrel distortion of 5 % at 800 px from the centre (OpenCV k1 of about -0.1 at f = 1200).
const BARREL: f64 = -0.05 / (800.0 * 800.0);

#[test]
fn fit_recovers_the_division_models_parameter() {
    let (path, dots) = distorted_view(BARREL, 0.0, 0);
    let (world, image): (Vec<Point3<f64>>, Vec<Point2<f64>>) = dots.iter().enumerate().map(|(i, d)| (path.points_m[i], d.centre_px)).unzip();
    let (rms, division) = fit(&world, &image, CENTRE).unwrap();
    assert!((division.lambda / BARREL - 1.0).abs() < 0.01, "lambda {} against {BARREL}", division.lambda);
    assert!(rms < 0.01, "{rms} px");
    // Without the lens term the same view misses by 0.19 px (the course view is compact, and the
    // DLT absorbs most of the bend): the term is what fits it.
    let flat = Dlt::fit(&world, &image, None).unwrap().rms(&world, &image);
    assert!(flat > 0.1 && flat > 100.0 * rms, "{flat} px against {rms} px");
}

#[test]
fn undistort_inverts_the_closed_form_distortion() {
    let division = Division { centre: CENTRE, lambda: BARREL };
    for u in [Point2::new(10.0, 20.0), Point2::new(1270.0, 1000.0), CENTRE] {
        assert!((division.undistort(&distort(&u, BARREL)) - u).norm() < 1e-9);
    }
}

#[test]
fn a_stretch_one_index_off_is_corrected_and_the_lens_kept() {
    // Dots 0-90 of the distorted view with 0.05 px noise; from index 45 on, labelled one index
    // high and then one more from 70 (a shift and a miscounted skip: two steps of the search).
    let (path, dots) = distorted_view(BARREL, 0.05, 1);
    let truth: Labels = (0..=90).map(|i| (i, i)).collect();
    let wrong: Labels = truth.iter().map(|&(i, j)| (i + usize::from(i >= 45) + usize::from(i >= 70), j)).collect();
    let checked = best_rival(&dots, &path, wrong, CENTRE, 2.5).unwrap();
    assert_eq!(checked.chosen, truth);
    let (_, division) = checked.lens.expect("the lens term is significant");
    // 0.05 px of noise against the 0.19 px the lens term explains in this compact view: lambda
    // within 10 %.
    assert!((division.lambda / BARREL - 1.0).abs() < 0.1, "lambda {}", division.lambda);
    // The right labelling is kept as it is.
    assert_eq!(best_rival(&dots, &path, truth.clone(), CENTRE, 2.5).unwrap().chosen, truth);
}

#[test]
fn the_lens_term_is_left_out_where_it_explains_nothing() {
    // An undistorted view with 0.05 px noise, and one whose dots stray by 7 mm: no lens.
    let (path, dots) = distorted_view(0.0, 0.05, 2);
    let all: Labels = (0..dots.len()).map(|i| (i, i)).collect();
    assert!(best_rival(&dots, &path, all.clone(), CENTRE, 2.5).unwrap().lens.is_none());
    let (path, dots, _) = jittered(0.007, 3);
    assert!(best_rival(&dots, &path, all, CENTRE, 2.5).unwrap().lens.is_none());
}

#[test]
fn a_labelling_its_own_reversal_explains_better_is_caught() {
    // Dots 30-99 of a 7 mm view, labelled rightly and run backwards (index i as 100 - i: the
    // exact reversal, whose own reversal is the truth).
    let (path, dots, _) = jittered(0.007, 4);
    let truth: Labels = (30..100).map(|i| (i, i)).collect();
    let reversed = assign::mirror(&truth, 100, path.len());
    assert_eq!(reversed.len(), truth.len());
    let params = SPathFitParams::default();
    assert!(!checks::reversal_explains_better(&dots, &path, &truth, &params));
    assert!(checks::reversal_explains_better(&dots, &path, &reversed, &params));
}

#[test]
fn contenders_the_lens_term_fits_far_worse_drop_out_unless_the_least_cost_is_one_of_them() {
    // Dots 0-90 of the distorted view with 0.05 px noise, labelled rightly and with the stretch
    // from index 45 one index high (a shift the projective gates cannot tell apart).
    let (path, dots) = distorted_view(BARREL, 0.05, 5);
    let truth: Labels = (0..=90).map(|i| (i, i)).collect();
    let shifted: Labels = truth.iter().map(|&(i, j)| (i + usize::from(i >= 45), j)).collect();
    let (right, wrong) = (Assignment::from_labels(truth.clone()), Assignment::from_labels(shifted));
    // The right labelling first (the least cost): the shift drops out.
    let kept = lens_settled(&dots, &path, vec![&right, &wrong], CENTRE, 2.5);
    assert_eq!(kept.len(), 1);
    assert_eq!(kept[0].labels, truth);
    // The shift first: the least-cost contender is one the lens term fits far worse, so none
    // drops out (the dispute stands, and the assignment refuses the view).
    assert_eq!(lens_settled(&dots, &path, vec![&wrong, &right], CENTRE, 2.5).len(), 2);
    // Two contenders the lens term fits alike both stay.
    let again = Assignment::from_labels(truth.clone());
    assert_eq!(lens_settled(&dots, &path, vec![&right, &again], CENTRE, 2.5).len(), 2);
}
