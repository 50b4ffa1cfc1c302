//! The loops' bead-centroid bias ([`super::observe::CentroidBias`]), cached across steps: when it
//! is recomputed ([`BiasRefresh`]) and how the recomputation runs beside the loop ([`BiasCache`]).
//!
//! A refresh traces every bead's blob (45-80 ms on 2 cores); a step's PnP takes 0.2 ms. So a loop
//! does not wait for it: the step that finds the bias stale starts the new one on a worker thread
//! and corrects its own dots with the bias it has; the next step takes the new bias (waiting for
//! it if the worker has not finished, so a run is the same whatever the threads' timing). The
//! bias a step uses is then at most one refresh interval plus one step old; the first step has none
//! (its dots uncorrected: about 1 px at the course's distances, a few millimetres of the pose when
//! the loop starts far from its goal).

use std::sync::{Arc, OnceLock};

use nalgebra::Isometry3;

use synthcam_geometry::pnp::{pnp_general, refine_pose, PnpError, PnpResult};
use synthcam_scene::Scene;

use crate::observe::{dot_points, CentroidBias, Dots, LOOP_SAMPLING};

/// When a loop recomputes its cached centroid bias ([`pose_from_dots_cached`]): once the plain
/// PnP pose has moved more than `mm` and `deg` from where it was computed, or, with a `goal`,
/// more than `share` of the pose's distance and angle to the goal where that is more. The bias
/// changes by about 1e-3 px per mm at the course's distances: far from the goal a bias that many
/// millimetres stale is a small share of the error the law corrects, and near it the bias is
/// fresh to `mm` and `deg`, as the final pose needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasRefresh {
    /// Movement that always recomputes, millimetres.
    pub mm: f64,
    /// Turn that always recomputes, degrees.
    pub deg: f64,
    /// The pose the loop drives to, if it has one.
    pub goal: Option<Isometry3<f64>>,
    /// Share of the distance to the goal the pose may move before the bias is recomputed.
    pub share: f64,
}

impl Default for BiasRefresh {
    /// 5 mm, 1 degree, no goal, a fifth of the way to it.
    fn default() -> Self {
        Self { mm: 5.0, deg: 1.0, goal: None, share: 0.2 }
    }
}

impl BiasRefresh {
    /// The default refresh for a loop that drives to `goal` (its `cam_from_target`).
    pub fn towards(goal: Isometry3<f64>) -> Self {
        Self { goal: Some(goal), ..Self::default() }
    }

    /// The movement (mm, degrees) from its pose that leaves the bias computed at `at` in use.
    fn tolerance(&self, at: &Isometry3<f64>) -> (f64, f64) {
        let Some(goal) = self.goal else { return (self.mm, self.deg) };
        let d = goal.inverse() * at;
        (self.mm.max(self.share * d.translation.vector.norm() * 1e3), self.deg.max(self.share * d.rotation.angle().to_degrees()))
    }
}

/// A loop's cached bias ([`pose_from_dots_cached`]): the bias in use and the one being computed
/// on a worker thread. Start with `BiasCache::default()` (empty: the first step uses its dots
/// uncorrected and starts the bias that the next step takes).
#[derive(Debug, Clone, Default)]
pub struct BiasCache {
    current: Option<CentroidBias>,
    /// The pose and result slot of the bias being computed.
    next: Option<(Isometry3<f64>, Slot)>,
}

/// Where the worker leaves its bias (`None`: it failed, and the loop computes the bias itself).
type Slot = Arc<OnceLock<Option<CentroidBias>>>;

impl PartialEq for BiasCache {
    fn eq(&self, other: &Self) -> bool {
        self.current == other.current && self.next.as_ref().map(|n| n.0) == other.next.as_ref().map(|n| n.0)
    }
}

impl BiasCache {
    /// The bias in use, if any.
    pub fn current(&self) -> Option<&CentroidBias> {
        self.current.as_ref()
    }

    /// Take the bias the worker computed (waiting for it), if one was started.
    fn settle(&mut self, scene: &Scene) {
        if let Some((at, slot)) = self.next.take() {
            let done = slot.wait().clone();
            self.current = Some(done.unwrap_or_else(|| bias_at(scene, at)));
        }
    }

    /// Start computing the bias at `at` on a worker thread (computed here if no thread starts).
    fn start(&mut self, scene: &Scene, at: Isometry3<f64>) {
        let slot: Slot = Arc::new(OnceLock::new());
        let (job_slot, job_scene) = (slot.clone(), scene.clone());
        let job = move || {
            let b = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| bias_at(&job_scene, at))).ok();
            let _ = job_slot.set(b);
        };
        if std::thread::Builder::new().name("synthcam-bias".into()).spawn(job).is_err() {
            let _ = slot.set(Some(bias_at(scene, at)));
        }
        self.next = Some((at, slot));
    }
}

fn bias_at(scene: &Scene, at: Isometry3<f64>) -> CentroidBias {
    CentroidBias::sampled(&Scene { cam_from_target: at, ..scene.clone() }, &LOOP_SAMPLING)
}

/// PnP on detected dots corrected by a cached bias, recomputed beside the loop ([`BiasCache`]) once
/// the plain PnP pose has moved further than `refresh` allows from where the bias in use was
/// computed. For loops, where most steps barely move.
///
/// # Errors
/// PnP failed.
pub fn pose_from_dots_cached(scene: &Scene, dots: &Dots, cache: &mut BiasCache, refresh: &BiasRefresh) -> Result<PnpResult, PnpError> {
    cache.settle(scene);
    let points = dot_points(scene, dots);
    let plain = pnp_general(&scene.camera, &points, &dots.pixels_px)?;
    let stale = cache.current.as_ref().is_none_or(|c| {
        let (mm, deg) = refresh.tolerance(&c.at);
        !c.is_near(&plain.cam_from_target, mm, deg)
    });
    if stale {
        cache.start(scene, plain.cam_from_target);
    }
    let corrected = cache.current.as_ref().map_or_else(|| dots.pixels_px.clone(), |c| c.correct(dots));
    Ok(refine_pose(&scene.camera, &points, &corrected, &plain.cam_from_target))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The course's view with dots at the truth's blob centroids: the first call has no bias yet
    /// (its pose carries the centroids' bias: 6.4 mm), the second takes the one the worker computed
    /// at that first pose and lands within 0.1 mm of the true pose (the bias moves by ~1e-3 px per
    /// mm, so one computed 6.4 mm away is ~6e-3 px off); a clone shares the pending bias.
    #[test]
    fn the_bias_arrives_one_step_later_and_corrects_the_pose() {
        let scene = synthcam_scene::file::parse_scene(include_str!("../assets/scenes/course_s_path.toml")).expect("scene");
        let truth = CentroidBias::at(&scene);
        let pts = scene.target.feature_points_m();
        let (ids, pixels_px): (Vec<usize>, Vec<_>) =
            pts.iter().enumerate().filter_map(|(i, p)| truth.bias_px[i].map(|b| (i, scene.camera.project(&(scene.cam_from_target * p)).pixel_px + b))).unzip();
        let dots = Dots { ids, pixels_px };
        let error_mm = |r: &PnpResult| (r.cam_from_target.translation.vector - scene.cam_from_target.translation.vector).norm() * 1e3;
        let mut cache = BiasCache::default();
        let first = pose_from_dots_cached(&scene, &dots, &mut cache, &BiasRefresh::default()).expect("pnp");
        assert!(cache.current().is_none(), "the first step has no bias");
        let twin = cache.clone();
        let second = pose_from_dots_cached(&scene, &dots, &mut cache, &BiasRefresh::default()).expect("pnp");
        let mut twin = twin;
        let again = pose_from_dots_cached(&scene, &dots, &mut twin, &BiasRefresh::default()).expect("pnp");
        eprintln!("pose error: uncorrected {:.3} mm, corrected {:.5} mm", error_mm(&first), error_mm(&second));
        assert!(error_mm(&first) > 0.5, "{}", error_mm(&first));
        assert!(error_mm(&second) < 0.1, "{}", error_mm(&second));
        assert_eq!(second, again);
        assert_eq!(cache, twin);
    }
}
