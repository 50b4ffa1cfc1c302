//! Residuals of an indexed S-path against one projective fit of the whole path: how far each
//! dot lies from where the fit puts its path point, in pixels and along the path.

use nalgebra::{Point2, Point3};

use super::dlt::Dlt;
use crate::s_path_order::IndexedDot;
use synthcam_core::target::SPath;

/// One indexed dot's residual against the whole path's fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathResidual {
    /// Detected centre minus the projection of the dot's nominal path point by the projective
    /// camera (DLT) fitted to all the indexed dots, pixels.
    pub residual_px: nalgebra::Vector2<f64>,
    /// The residual's length turned into metres on the target with the local scale along the
    /// path (projected over nominal spacing of the path neighbours): how far the dot seems to
    /// stray from its nominal place.
    pub deviation_m: f64,
}

/// Residuals of the indexed dots against the DLT fitted to all of them: how far each dot sits
/// from where the nominal path puts it (a hand-painted or glued target strays by millimetres).
/// Bead centroids carry the bead's own offset from its path point (about 1.4 px at the course's
/// pose, see the README), lens distortion a smooth part. `None` with fewer than 6 dots or a
/// degenerate fit.
pub fn path_residuals(ordered: &[IndexedDot], path: &SPath) -> Option<Vec<PathResidual>> {
    let valid: Vec<&IndexedDot> = ordered.iter().filter(|d| d.index < path.len()).collect();
    if valid.len() != ordered.len() {
        return None;
    }
    let world: Vec<Point3<f64>> = valid.iter().map(|d| path.points_m[d.index]).collect();
    let image: Vec<Point2<f64>> = valid.iter().map(|d| d.centre_px).collect();
    let dlt = Dlt::fit(&world, &image, None)?;
    valid
        .iter()
        .map(|d| {
            let q = dlt.project(&path.points_m[d.index])?;
            let scales: Vec<f64> = [d.index.checked_sub(1), Some(d.index + 1)]
                .into_iter()
                .flatten()
                .filter(|&k| k < path.len())
                .filter_map(|k| {
                    let world_m = (path.points_m[k] - path.points_m[d.index]).norm();
                    Some((dlt.project(&path.points_m[k])? - q).norm() / world_m)
                })
                .filter(|s| s.is_finite() && *s > 0.0)
                .collect();
            let px_per_m = scales.iter().sum::<f64>() / scales.len().max(1) as f64;
            let residual_px = d.centre_px - q;
            Some(PathResidual { residual_px, deviation_m: if px_per_m > 0.0 { residual_px.norm() / px_per_m } else { f64::NAN } })
        })
        .collect()
}
