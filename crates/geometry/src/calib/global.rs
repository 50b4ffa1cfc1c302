//! The global optimum of the calibration, not luck's: Levenberg-Marquardt runs from several
//! starts, then a perturbed-restart check.
//!
//! Starts: Zhang's closed form for the OpenCV models (the pinhole part is globally determined
//! by the homographies; the distortion starts at zero, as in OpenCV), and for the models beyond
//! five coefficients also the five-coefficient fit (`ladder_start`); for fisheye the focal
//! length search of [`super::init_wide`] under the equidistant lens; for Double Sphere the
//! lowest points of the cost's profile over `xi`, started from a fisheye fit (`ds_starts`),
//! and the base start (`xi = 0, alpha = 0.5` at the best focal length); every start refined to
//! convergence.
//! Kalibr and basalt start the unified / Double Sphere models from one fixed `xi`; the cost
//! surface of Double Sphere has a valley along which `fx` and `xi` trade (a larger `xi` bends
//! rays as a shorter focal length does), and a single start can settle in the valley's wrong
//! end. A start given by the user ([`super::CalibParams::initial`]) is one more start.
//!
//! Then the check: from the best fit, the intrinsics are perturbed (`restart_cameras`: focal
//! length x 0.7 and x 1.4, Double Sphere's `xi` moved with it along the valley), every view's
//! pose is re-solved under the perturbed camera and Levenberg-Marquardt runs again (on a
//! subsample of each view, `restart_check`). A restart that ends lower replaces the fit, so the
//! reported optimum is never above what the restarts find, and [`Search::restart_improved`]
//! says whether one did.
//!
//! Reference: the multi-start strategy for nonlinear least squares, e.g. J. Nocedal, S. Wright,
//! *Numerical Optimization*, 2nd ed., section 1 ("global optimisation"); V. Usenko, N. Demmel,
//! D. Cremers, "The Double Sphere camera model", 3DV 2018 (the model; its `xi = 0, alpha = 0.5`
//! start).

use nalgebra::{Point2, Vector2, Vector3, Vector6};

use super::refine::{pose_vector, refine, vector_of, Refined, State, View, Warp};
use super::{init_wide, zhang, CalibError, CalibModel, CalibParams};
use synthcam_core::camera::{CameraModel, DoubleSphere, ImageSize, Lens, LensKind, MAX_LENS_PARAMS, N_INTRINSICS};

/// The profile's `xi` grid: this range in this many steps; `alpha` over (0, 1) in
/// [`DS_ALPHA_STEPS`] steps for each.
const DS_XI_RANGE: (f64, f64) = (-0.9, 0.95);
const DS_XI_STEPS: usize = 37;
const DS_ALPHA_STEPS: usize = 100;
/// Levenberg-Marquardt iterations per profile point.
const DS_PROFILE_ITERATIONS: usize = 50;
/// Profile points refined to convergence: the lowest ones at least [`DS_APART`] apart in `xi`.
const DS_STARTS: usize = 2;
const DS_APART: f64 = 0.2;
/// Observed rays the conversion fits at most.
const MAX_RADII: usize = 400;

/// How the optimum was searched for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Search {
    /// Starts refined to convergence.
    pub starts: usize,
    /// Perturbed restarts run from the best start's fit.
    pub restarts: usize,
    /// Whether a restart ended lower than every start (the fit reported is then the restart's).
    pub restart_improved: bool,
    /// The lowest cost a restart reached over the best start's, on the points the restarts use
    /// (at least 1 - 1e-6 when no restart found a lower optimum).
    pub best_restart_ratio: f64,
}

/// A restart counts as lower when it beats the fit by this fraction of its cost (below it the
/// two are the same optimum to the convergence test's precision).
const IMPROVEMENT: f64 = 1e-6;

/// The best of Levenberg-Marquardt from every start, then the perturbed-restart check.
///
/// # Errors
/// [`CalibError::Degenerate`] when no start exists or every run's normal equations are singular.
pub(super) fn fit(views: &[View], size: ImageSize, params: &CalibParams, free: &[usize]) -> Result<(Refined, Search), CalibError> {
    let mut starts = starts(views, size, params)?;
    // The warp starts flat (every start assumes a flat board).
    for s in &mut starts {
        s.warp = Warp { k: [0.0; 2], extent: params.board_warp };
    }
    let mut search = Search { starts: starts.len(), best_restart_ratio: f64::INFINITY, ..Default::default() };
    let singular = || CalibError::Degenerate { reason: "the normal equations are singular".into() };
    let best = best_of(starts.into_iter().filter_map(|s| refine(size, s, views, free, params.max_iterations))).ok_or_else(singular)?;
    let best = restart_check(best, views, size, params, free, &mut search);
    Ok((best, search))
}

/// The perturbed-restart check of `best`. The restarts run on about
/// [`init_wide::SEARCH_POINTS`] points per view (a quarter of the cost or less), against `best`
/// polished on the same points; a restart that ends lower there is refined on every point and
/// replaces `best` if it ends lower there too.
fn restart_check(best: Refined, views: &[View], size: ImageSize, params: &CalibParams, free: &[usize], search: &mut Search) -> Refined {
    let sparse = init_wide::sparse(views);
    let Some(reference) = refine(size, best.state.clone(), &sparse, free, params.max_iterations) else { return best };
    let camera = super::refine::camera_of(size, best.state.kind, &best.state.a);
    let mut out = best;
    for cam in restart_cameras(&camera, free) {
        let restart = start_under(&cam, &sparse).map(|st| State { warp: out.state.warp, ..st });
        let Some(r) = restart.and_then(|st| refine(size, st, &sparse, free, params.max_iterations)) else { continue };
        search.restarts += 1;
        search.best_restart_ratio = search.best_restart_ratio.min(r.cost / reference.cost.max(f64::MIN_POSITIVE));
        if r.cost < reference.cost * (1.0 - IMPROVEMENT) {
            if let Some(full) = refine(size, r.state, views, free, params.max_iterations).filter(|f| f.cost < out.cost * (1.0 - IMPROVEMENT)) {
                search.restart_improved = true;
                out = full;
            }
        }
    }
    out
}

/// The run with the lowest finite cost.
fn best_of(runs: impl Iterator<Item = Refined>) -> Option<Refined> {
    runs.filter(|r| r.cost.is_finite()).min_by(|a, b| a.cost.total_cmp(&b.cost))
}

/// Every start of the model (see the module's documentation).
fn starts(views: &[View], size: ImageSize, params: &CalibParams) -> Result<Vec<State>, CalibError> {
    let kind = params.model.kind();
    let mut out = Vec::new();
    match kind {
        LensKind::OpenCv => {
            let zhang = zhang_start(views, params)?;
            out.extend(ladder_start(&zhang, views, size, params));
            out.push(zhang);
        }
        LensKind::Fisheye => out.extend(wide_start(size, init_wide::base_lens(kind), views)),
        LensKind::DoubleSphere => {
            out.extend(ds_starts(size, views, params));
            out.extend(wide_start(size, init_wide::base_lens(kind), views));
        }
    }
    if out.is_empty() {
        return Err(CalibError::Degenerate { reason: format!("no {} focal length fits every view", params.model) });
    }
    if let Some(cam) = params.initial.filter(|c| c.lens.kind() == kind) {
        out.extend(start_under(&cam, views));
    }
    Ok(out)
}

/// The OpenCV models beyond five coefficients (rational, thin prism, tilted) also start from the
/// five-coefficient fit (the rest at zero): their extra coefficients trade numerator against
/// denominator over a board's radii, and Levenberg-Marquardt from zero distortion can wander into
/// that valley's far end (coefficients in the thousands) where the well-posed model's optimum
/// lies next to the answer. The model ladder users of OpenCV climb by hand.
fn ladder_start(zhang: &State, views: &[View], size: ImageSize, params: &CalibParams) -> Option<State> {
    if params.model.n_lens_params() <= 5 {
        return None;
    }
    // The five-coefficient model's free set under the user's options (the start is flat).
    let free = super::free_parameters(&CalibParams { model: CalibModel::OpenCv5, board_warp: None, ..*params });
    refine(size, zhang.clone(), views, &free, params.max_iterations).map(|r| r.state)
}

fn wide_start(size: ImageSize, lens: Lens, views: &[View]) -> Option<State> {
    init_wide::initial(size, lens, views).map(|(a, poses)| State::flat(lens.kind(), a, poses))
}

/// Double Sphere starts from a fisheye fit and the profile of the cost over `xi`.
///
/// The same views are first calibrated with the Kannala-Brandt model: its start (the equidistant
/// lens at the best focal length) does not depend on `xi` or `alpha`, and its radial polynomial
/// follows any central lens over the angles seen, so its poses and principal point are close to
/// the truth's. Then, for every `xi` of a grid, Double Sphere's radial curve is fitted to the
/// fisheye's over the observed rays' angles (`alpha` on a fine grid, the scale in closed form,
/// [`radial_fit`]), and Levenberg-Marquardt over everything but `xi`, on about
/// [`init_wide::SEARCH_POINTS`] points per view, gives the profile's value at that `xi`. The
/// [`DS_STARTS`] lowest profile points at least [`DS_APART`] apart start the full refinement. The
/// cost has a valley along which `fx` and `xi` trade (`fx / (1 + xi)` is the focal length of the
/// axis); a single start, or a single converted curve, can fall into its wrong end, the profile's
/// minimum over the grid cannot.
fn ds_starts(size: ImageSize, views: &[View], params: &CalibParams) -> Vec<State> {
    let Some(kb) = fisheye_fit(size, views, params) else { return Vec::new() };
    let Lens::Fisheye(lens) = super::refine::camera_of(size, LensKind::Fisheye, &kb.state.a).lens else { return Vec::new() };
    let radii = observed_radii(views, &kb.state.poses);
    let d: Vec<f64> = radii.iter().map(|&r| lens.distort(&Vector2::new(r, 0.0)).x).collect();
    let sparse = init_wide::sparse(views);
    // Everything but xi (alpha free whatever the user fixes: this is a start).
    let mut fix_distortion = [false; MAX_LENS_PARAMS];
    fix_distortion[0] = true;
    let free =
        super::free_parameters(&CalibParams { model: CalibModel::DoubleSphere, estimate_skew: params.estimate_skew, fix_distortion, ..Default::default() });
    let mut profile: Vec<Refined> = Vec::new();
    for i in 0..=DS_XI_STEPS {
        let xi = DS_XI_RANGE.0 + (DS_XI_RANGE.1 - DS_XI_RANGE.0) * i as f64 / DS_XI_STEPS as f64;
        let Some((alpha, c)) = radial_fit(xi, &radii, &d) else { continue };
        let mut a = kb.state.a;
        a[0] *= c;
        a[1] *= c;
        a[5..].fill(0.0);
        (a[5], a[6]) = (xi, alpha);
        let start = State::flat(LensKind::DoubleSphere, a, kb.state.poses.clone());
        profile.extend(refine(size, start, &sparse, &free, DS_PROFILE_ITERATIONS).filter(|r| r.cost.is_finite()));
    }
    profile.sort_by(|a, b| a.cost.total_cmp(&b.cost));
    let mut chosen: Vec<State> = Vec::new();
    for r in profile {
        if chosen.len() < DS_STARTS && chosen.iter().all(|c| (c.a[5] - r.state.a[5]).abs() >= DS_APART) {
            chosen.push(r.state);
        }
    }
    chosen
}

/// The Kannala-Brandt calibration of the views, every lens coefficient free.
fn fisheye_fit(size: ImageSize, views: &[View], params: &CalibParams) -> Option<Refined> {
    let start = wide_start(size, init_wide::base_lens(LensKind::Fisheye), views)?;
    let free = super::free_parameters(&CalibParams { model: CalibModel::Fisheye, estimate_skew: params.estimate_skew, ..Default::default() });
    refine(size, start, views, &free, params.max_iterations)
}

/// For Double Sphere at `xi`, the `alpha` (grid of [`DS_ALPHA_STEPS`] over (0, 1)) and scale `c`
/// whose radial curve `c m(r)` best fits `d` (least squares, `c` in closed form
/// `sum(d m) / sum(m^2)`) at the radii `r` (ascending), every radius in the model's valid region.
fn radial_fit(xi: f64, radii: &[f64], d: &[f64]) -> Option<(f64, f64)> {
    let mut best: Option<(f64, f64, f64)> = None;
    for j in 1..DS_ALPHA_STEPS {
        let ds = DoubleSphere { xi, alpha: j as f64 / DS_ALPHA_STEPS as f64 };
        if radii.last().is_some_and(|&r| r > ds.max_radius()) {
            continue;
        }
        let m: Vec<f64> = radii.iter().map(|&r| ds.distort(&Vector2::new(r, 0.0)).x).collect();
        let c = d.iter().zip(&m).map(|(d, m)| d * m).sum::<f64>() / m.iter().map(|m| m * m).sum::<f64>();
        let cost: f64 = d.iter().zip(&m).map(|(d, m)| (c * m - d).powi(2)).sum();
        if cost.is_finite() && best.is_none_or(|b| cost < b.0) {
            best = Some((cost, ds.alpha, c));
        }
    }
    best.map(|(_, alpha, c)| (alpha, c))
}

/// The radii `|(x, y)| / z` of the observed points in front of the camera under `poses`, ascending
/// (at most about [`MAX_RADII`], spread evenly over the points).
fn observed_radii(views: &[View], poses: &[Vector6<f64>]) -> Vec<f64> {
    let n: usize = views.iter().map(Vec::len).sum();
    let step = n.div_ceil(MAX_RADII).max(1);
    let mut radii: Vec<f64> = views
        .iter()
        .zip(poses)
        .flat_map(|(v, pose)| {
            let rot = synthcam_core::math::so3::rotation_from_rvec(&Vector3::new(pose[0], pose[1], pose[2]));
            let t = Vector3::new(pose[3], pose[4], pose[5]);
            v.iter().map(move |(x, _)| rot * x.coords + t)
        })
        .step_by(step)
        .filter(|p| p.z > 0.0)
        .map(|p| p.xy().norm() / p.z)
        .collect();
    radii.sort_by(f64::total_cmp);
    radii
}

/// Zhang's closed form: intrinsics and every view's pose (OpenCV models).
fn zhang_start(views: &[View], params: &CalibParams) -> Result<State, CalibError> {
    let hs = views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (src, dst): (Vec<Point2<f64>>, Vec<Point2<f64>>) = v.iter().map(|(x, q)| (x.xy(), *q)).unzip();
            synthcam_core::math::homography::homography(&src, &dst).ok_or_else(|| CalibError::Degenerate { reason: format!("no homography for view {i}") })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let k0 = zhang::intrinsics_from_homographies(&hs, !params.estimate_skew)?;
    let poses: Vec<Vector6<f64>> = hs.iter().map(|h| pose_vector(&zhang::pose_from_homography(h, &k0))).collect();
    let mut a = [0.0; N_INTRINSICS];
    a[..5].copy_from_slice(&[k0.fx, k0.fy, k0.cx, k0.cy, k0.skew]);
    Ok(State::flat(params.model.kind(), a, poses))
}

/// The perturbed cameras the check restarts from: focal length x 0.7 and x 1.4, the lens
/// parameters kept, except Double Sphere's `xi`, moved along the valley where the two trade
/// (`fx / (1 + xi)` held: `1 + xi` scaled as the focal length); only free parameters move.
fn restart_cameras(camera: &CameraModel, free: &[usize]) -> Vec<CameraModel> {
    [0.7, 1.4]
        .iter()
        .map(|&scale| {
            let mut a = vector_of(camera);
            for i in [0, 1] {
                if free.contains(&i) {
                    a[i] *= scale;
                }
            }
            if camera.lens.kind() == LensKind::DoubleSphere && free.contains(&5) {
                a[5] = (scale * (1.0 + a[5]) - 1.0).clamp(-0.9, 0.99);
            }
            super::refine::camera_of(camera.size, camera.lens.kind(), &a)
        })
        .collect()
}

/// A start at `camera` with every view's pose solved under it ([`poses_under`] without the
/// refinement); `None` where a view has no pose.
pub(super) fn start_under(camera: &CameraModel, views: &[View]) -> Option<State> {
    let poses = views.iter().map(|v| initial_pose(camera, v)).collect::<Option<Vec<_>>>()?;
    Some(State::flat(camera.lens.kind(), vector_of(camera), poses))
}

/// One view's pose under `camera`: from the homography between the board and the unprojected
/// rays near the axis ([`init_wide::view_pose`]); where that fails, as under a lens model that
/// cannot follow the lens, from the board-to-pixel homography and K.
fn initial_pose(camera: &CameraModel, view: &View) -> Option<Vector6<f64>> {
    if let Some((pose, _)) = init_wide::view_pose(camera, view) {
        return Some(pose_vector(&pose));
    }
    let (src, dst): (Vec<Point2<f64>>, Vec<Point2<f64>>) = view.iter().map(|(x, q)| (x.xy(), *q)).unzip();
    let h = synthcam_core::math::homography::homography(&src, &dst)?;
    Some(pose_vector(&zhang::pose_from_homography(&h, &camera.intrinsics)))
}

/// The poses of `views` under a fixed `camera` and board `warp`: each from [`initial_pose`], then
/// refined together with every intrinsic fixed.
///
/// # Errors
/// [`CalibError::Degenerate`] where a view has no homography or the normal equations are singular.
pub(super) fn poses_under(camera: &CameraModel, warp: Warp, views: &[View], size: ImageSize, max_iterations: usize) -> Result<Vec<Vector6<f64>>, CalibError> {
    let init = start_under(camera, views).ok_or_else(|| CalibError::Degenerate { reason: "a view has no homography under the camera".into() })?;
    let init = State { warp, ..init };
    let r = refine(size, init, views, &[], max_iterations).ok_or_else(|| CalibError::Degenerate { reason: "poses: singular normal equations".into() })?;
    Ok(r.state.poses)
}
