//! Per-image pose sampling of a dataset: image k's pose and noise seed depend only on the spec's
//! seed and k, so any shard, any order and any resume give the same image k.
//!
//! Image k uses ChaCha8 keyed by the spec's `seed` on stream k. It first draws the render (noise)
//! seed, then poses until one meets the visibility constraint (at most [`MAX_DRAWS_PER_IMAGE`]).

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::error::SpecError;
use super::rng::image_rng;
use super::spec::{BoardRanges, DatasetPlan, PoseMode, TiltFrom};
use synthcam_core::robot::{base_from_tool, Joints};
use synthcam_scene::Scene;

/// Bound on the pose draws of one image.
pub const MAX_DRAWS_PER_IMAGE: usize = 10_000;

/// Draws of the up-front feasibility check.
pub const FEASIBILITY_DRAWS: usize = 500;

/// One sampled image.
#[derive(Debug, Clone, PartialEq)]
pub struct SampledView {
    /// Image index.
    pub k: u64,
    /// The pose.
    pub cam_from_target: Isometry3<f64>,
    /// Robot joints (robot mode), radians.
    pub joints_rad: Option<[f64; 6]>,
    /// Noise seed of the render.
    pub render_seed: u64,
    /// Poses drawn to meet the constraint.
    pub draws: usize,
}

/// Centre of the bounding box of the target's feature points (target frame).
fn target_centre(plan: &DatasetPlan) -> Vector3<f64> {
    let pts = plan.target.feature_points_m();
    let (mut lo, mut hi) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
    for p in &pts {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    if pts.is_empty() {
        Vector3::zeros()
    } else {
        0.5 * (lo + hi)
    }
}

fn uniform(rng: &mut ChaCha8Rng, r: [f64; 2]) -> f64 {
    if r[0] == r[1] {
        r[0]
    } else {
        rng.random_range(r[0]..=r[1])
    }
}

fn board_pose(rng: &mut ChaCha8Rng, b: &BoardRanges, centre: &Vector3<f64>, front_from_target: UnitQuaternion<f64>) -> Isometry3<f64> {
    let d = uniform(rng, b.distance_m);
    let tilt = uniform(rng, b.tilt_deg).to_radians();
    let azimuth = rng.random_range(0.0..std::f64::consts::TAU);
    let roll = uniform(rng, b.roll_deg).to_radians();
    let (ox, oy) = (uniform(rng, b.offset_x_m), uniform(rng, b.offset_y_m));
    let axis = Unit::new_normalize(Vector3::new(azimuth.cos(), azimuth.sin(), 0.0));
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll) * UnitQuaternion::from_axis_angle(&axis, tilt);
    let at = Vector3::new(ox, oy, d);
    // Tilted from the line of sight: the axis-relative rotation turned onto the direction of the
    // target centre (the shortest rotation from +z to it).
    let rot = match b.tilt_from {
        TiltFrom::Axis => rot,
        TiltFrom::Sight => UnitQuaternion::rotation_between(&Vector3::z(), &at).unwrap_or_else(UnitQuaternion::identity) * rot,
    };
    // Printed side towards the camera (a target whose z points out of its page turns over).
    let rot = rot * front_from_target;
    Isometry3::from_parts(Translation3::from(at - rot * centre), rot)
}

/// One pose draw (and the joints in robot mode).
fn draw_pose(rng: &mut ChaCha8Rng, plan: &DatasetPlan, centre: &Vector3<f64>) -> (Isometry3<f64>, Option<[f64; 6]>) {
    match &plan.mode {
        PoseMode::Board(b) => (board_pose(rng, b, centre, plan.target.front_from_target()), None),
        PoseMode::Course => (synthcam_course::calibration_pose(rng) * Translation3::from(-centre), None),
        PoseMode::Robot(s) => {
            let spread = s.spread_rad;
            let q: [f64; 6] = std::array::from_fn(|i| s.q0_rad[i] + if spread > 0.0 { rng.random_range(-spread..spread) } else { 0.0 });
            let (tool_from_cam, world_from_base) = s.truth();
            let world_from_cam = world_from_base * base_from_tool(&Joints::from(q)) * tool_from_cam;
            (world_from_cam.inverse(), Some(q))
        }
    }
}

/// Whether the view meets the visibility constraint: in one camera ([`camera_meets`]), or in at
/// least `min_cameras` of a rig's, every one of which must be able to render its image
/// ([`synthcam_scene::target_in_reach`], as [`Scene::validate`] requires).
fn meets_constraint(plan: &DatasetPlan, pts: &[Point3<f64>], cam0_from_target: &Isometry3<f64>) -> bool {
    if plan.rig.is_empty() {
        return camera_meets(plan, &plan.camera, pts, cam0_from_target);
    }
    let mut meeting = 0;
    for m in &plan.rig {
        let cam_from_target = m.cam_from_cam0 * cam0_from_target;
        if synthcam_scene::target_in_reach(&m.camera, &cam_from_target, pts).is_err() {
            return false;
        }
        meeting += usize::from(camera_meets(plan, &m.camera, pts, &cam_from_target));
    }
    meeting >= plan.min_cameras
}

/// Whether every feature point projects inside `camera`'s image, `margin_px` from its border
/// (partial views: whether the fraction inside lies in the plan's range).
fn camera_meets(plan: &DatasetPlan, camera: &synthcam_core::camera::CameraModel, pts: &[Point3<f64>], cam_from_target: &Isometry3<f64>) -> bool {
    if let Some([lo, hi]) = plan.inside_fraction {
        let inside = pts.iter().filter(|p| camera.sees_all(cam_from_target, std::slice::from_ref(*p), plan.margin_px)).count();
        let f = inside as f64 / pts.len().max(1) as f64;
        return f >= lo && f <= hi;
    }
    if !plan.full_target_visible {
        return true;
    }
    camera.sees_all(cam_from_target, pts, plan.margin_px)
}

fn constraint_name(plan: &DatasetPlan) -> &'static str {
    if plan.inside_fraction.is_some() {
        "poses.inside_fraction"
    } else if matches!(plan.mode, PoseMode::Course) {
        "poses (course mode: full target visible)"
    } else {
        "poses.full_target_visible"
    }
}

fn infeasible(plan: &DatasetPlan, draws: usize) -> SpecError {
    SpecError::Infeasible {
        constraint: constraint_name(plan).into(),
        draws,
        hint: format!(
            "the target does not fit inside the {}x{} image with margin {} px at the sampled poses: allow larger distances, smaller tilts or offsets, or a smaller target",
            plan.camera.size.width, plan.camera.size.height, plan.margin_px
        ),
    }
}

/// Sample image k.
///
/// # Errors
/// [`SpecError::Infeasible`] when [`MAX_DRAWS_PER_IMAGE`] poses all miss the constraint.
pub fn sample_view(plan: &DatasetPlan, k: u64) -> Result<SampledView, SpecError> {
    let mut rng = image_rng(plan.seed, k);
    let render_seed: u64 = rng.random();
    let centre = target_centre(plan);
    let pts = plan.target.feature_points_m();
    for draws in 1..=MAX_DRAWS_PER_IMAGE {
        let (cam_from_target, joints_rad) = draw_pose(&mut rng, plan, &centre);
        if meets_constraint(plan, &pts, &cam_from_target) {
            return Ok(SampledView { k, cam_from_target, joints_rad, render_seed, draws });
        }
    }
    Err(infeasible(plan, MAX_DRAWS_PER_IMAGE))
}

/// Check up front, on [`FEASIBILITY_DRAWS`] draws of a stream no image uses, that the constraint
/// can be met; returns the acceptance rate.
///
/// # Errors
/// [`SpecError::Infeasible`] when no draw meets it.
pub fn check_feasible(plan: &DatasetPlan) -> Result<f64, SpecError> {
    let mut rng = image_rng(plan.seed, u64::MAX);
    let centre = target_centre(plan);
    let pts = plan.target.feature_points_m();
    let ok = (0..FEASIBILITY_DRAWS).filter(|_| meets_constraint(plan, &pts, &draw_pose(&mut rng, plan, &centre).0)).count();
    if ok == 0 {
        return Err(infeasible(plan, FEASIBILITY_DRAWS));
    }
    Ok(ok as f64 / FEASIBILITY_DRAWS as f64)
}

/// The scene of a sampled view: the plan's render settings with the view's seed and the
/// `[ranges]` fields drawn uniformly, in name order, from a stream seeded by that seed (so an
/// image's effects, like its noise, depend only on (seed, k)).
pub fn scene_of(plan: &DatasetPlan, view: &SampledView) -> Scene {
    let mut render = synthcam_scene::RenderSettings { seed: view.render_seed, ..plan.render };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(view.render_seed ^ 0x9e37_79b9_7f4a_7c15);
    for (field, [lo, hi]) in &plan.ranges {
        let v = if hi > lo { rng.random_range(*lo..=*hi) } else { *lo };
        // Fields and both ends were checked when the plan was built.
        let _ = synthcam_scene::effect_fields::set_field(&mut render, field, v);
    }
    let mut scene =
        Scene { camera: plan.camera, target: plan.target.clone(), cam_from_target: view.cam_from_target, render, objects: Vec::new(), background: None };
    plan.objects.place(&mut scene, plan.seed, view.k);
    // The placement was checked when the plan was built.
    scene.background = plan.background.as_ref().and_then(|b| b.for_image(plan.seed, view.k, &view.cam_from_target).ok());
    scene
}

/// Camera `i`'s scene of a sampled view of a rig dataset: [`scene_of`] (the same `[ranges]`
/// draws for every camera) seen through camera `i` (`cam_from_cam0 * cam0_from_target`), with a
/// noise seed of its own (camera 0 keeps the view's). `None` when `i` is not a rig camera.
pub fn rig_scene_of(plan: &DatasetPlan, view: &SampledView, i: usize) -> Option<Scene> {
    let (seed, cam_from_target) = rig_view(plan, view, i)?;
    let mut scene = scene_of(plan, view);
    scene.camera = plan.rig.get(i)?.camera;
    scene.cam_from_target = cam_from_target;
    scene.background = scene.background.map(|b| b.seen_from(&plan.rig[i].cam_from_cam0));
    scene.render.seed = seed;
    Some(scene)
}

/// Rig camera `i`'s noise seed and `cam_from_target` for a sampled view (what
/// [`rig_scene_of`] renders and the manifest records); `None` when `i` is not a rig camera.
pub fn rig_view(plan: &DatasetPlan, view: &SampledView, i: usize) -> Option<(u64, Isometry3<f64>)> {
    let m = plan.rig.get(i)?;
    Some((view.render_seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15), m.cam_from_cam0 * view.cam_from_target))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::spec::parse_dataset_spec;

    const TINY: &str = include_str!("../../assets/specs/tiny.toml");

    #[test]
    fn view_k_depends_only_on_seed_and_k() {
        let plan = parse_dataset_spec(TINY).unwrap();
        let a: Vec<_> = (0..6).map(|k| sample_view(&plan, k).unwrap()).collect();
        let b: Vec<_> = (0..6).rev().map(|k| sample_view(&plan, k).unwrap()).collect();
        for (x, y) in a.iter().zip(b.iter().rev()) {
            assert_eq!(x, y);
        }
        assert_ne!(a[0].cam_from_target, a[1].cam_from_target);
        assert_ne!(a[0].render_seed, a[1].render_seed);
        let plan2 = DatasetPlan { seed: plan.seed + 1, ..plan.clone() };
        assert_ne!(sample_view(&plan2, 0).unwrap().cam_from_target, a[0].cam_from_target);
    }

    #[test]
    fn sampled_views_meet_the_ranges_and_constraint() {
        let plan = parse_dataset_spec(TINY).unwrap();
        let PoseMode::Board(b) = plan.mode else { panic!("board") };
        let centre = target_centre(&plan);
        let pts = plan.target.feature_points_m();
        for k in 0..50 {
            let v = sample_view(&plan, k).unwrap();
            let c = v.cam_from_target * Point3::from(centre);
            assert!(c.z >= b.distance_m[0] - 1e-9 && c.z <= b.distance_m[1] + 1e-9, "{}", c.z);
            let normal = v.cam_from_target.rotation * Vector3::z();
            let tilt = normal.z.clamp(-1.0, 1.0).acos().to_degrees();
            assert!(tilt >= b.tilt_deg[0] - 1e-6 && tilt <= b.tilt_deg[1] + 1e-6, "{tilt}");
            assert!(meets_constraint(&plan, &pts, &v.cam_from_target));
        }
    }

    #[test]
    fn boards_tilted_from_the_line_of_sight_face_the_camera() {
        // The fisheye spec out to the field's edge: centres up to 80 degrees off-axis, each
        // board's normal within its tilt range of the line of sight (measured from the axis it
        // would be up to 125 degrees).
        let plan = parse_dataset_spec(include_str!("../../assets/specs/fisheye_edge_1280.toml")).unwrap();
        let PoseMode::Board(b) = plan.mode else { panic!("board") };
        assert_eq!(b.tilt_from, TiltFrom::Sight);
        let centre = target_centre(&plan);
        let mut widest: f64 = 0.0;
        for k in 0..30 {
            let v = sample_view(&plan, k).unwrap();
            let c = (v.cam_from_target * Point3::from(centre)).coords.normalize();
            let normal = v.cam_from_target.rotation * Vector3::z();
            let tilt = normal.dot(&c).clamp(-1.0, 1.0).acos().to_degrees();
            assert!(tilt <= b.tilt_deg[1] + 1e-6, "view {k}: {tilt} degrees from the line of sight");
            widest = widest.max(c.z.acos().to_degrees());
        }
        assert!(widest > 70.0, "{widest}");
        // Anything else is an error naming the choices.
        let bad = include_str!("../../assets/specs/fisheye_edge_1280.toml").replace("tilt_from = \"sight\"", "tilt_from = \"normal\"");
        let e = parse_dataset_spec(&bad).unwrap_err().to_string();
        assert!(e.contains("unknown variant `normal`, expected `axis` or `sight`"), "{e}");
    }

    #[test]
    fn impossible_constraint_is_reported() {
        let text = TINY.replace("distance_m = [0.45, 0.7]", "distance_m = [0.05, 0.1]");
        let plan = parse_dataset_spec(&text).unwrap();
        let e = check_feasible(&plan).unwrap_err().to_string();
        assert!(e.contains("full_target_visible"), "{e}");
    }
}
