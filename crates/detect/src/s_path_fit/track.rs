//! Carrying an S-path's labels from one frame of a sequence to the next (a servo loop's frames):
//! each blob is the previous frame's blob that it is the mutual nearest neighbour of, where every
//! blob moved less than [`TRACK_FRACTION`] of its distance to its nearest neighbour. Then the
//! pairing is the blobs' identity (see [`SPathTrack::carry`]), and labelling the frame costs a
//! nearest-neighbour search instead of the chains and the assignment of [`super::index_s_path`].

use nalgebra::Point2;

use super::dlt::Dlt;
use super::{correspondences, Labels};
use crate::dots::Dot;
use crate::s_path_order::{indexed, IndexedDot};
use synthcam_core::target::SPath;

/// How far a blob may move between frames, as a share of its distance to its nearest neighbour
/// in the previous frame.
pub const TRACK_FRACTION: f64 = 0.3;

/// A carried labelling's reprojection RMS (the DLT of all labelled dots) may exceed the previous
/// frame's by this factor ...
const RMS_GROWTH: f64 = 2.0;
/// ... plus this many pixels.
const RMS_SLACK_PX: f64 = 0.1;

/// The previous frame of a sequence: every blob detected in it, with the path index it was given
/// (`None`: detected but not placed), and the reprojection RMS of its labelling.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SPathTrack {
    blobs: Vec<(Point2<f64>, Option<usize>)>,
    rms_px: f64,
    carried: usize,
}

impl SPathTrack {
    /// Remember a frame's blobs and the labelling [`super::index_s_path`] or, `carried`,
    /// [`Self::carry`] gave them; an empty labelling forgets the sequence.
    pub fn remember(&mut self, dots: &[Dot], ordered: &[IndexedDot], path: &SPath, carried: bool) {
        let labels: Labels = ordered.iter().filter_map(|o| dots.iter().position(|d| d.centre_px == o.centre_px).map(|j| (o.index, j))).collect();
        let (world, image) = correspondences(&labels, dots, path);
        let rms = Dlt::fit(&world, &image, None).map(|d| d.rms(&world, &image));
        *self = match rms {
            Some(rms_px) if !labels.is_empty() => {
                let label_of = |j: usize| labels.iter().find(|l| l.1 == j).map(|l| l.0);
                let blobs = dots.iter().enumerate().map(|(j, d)| (d.centre_px, label_of(j))).collect();
                Self { blobs, rms_px, carried: self.carried + usize::from(carried) }
            }
            _ => Self::default(),
        };
    }

    /// Frames of the sequence whose labels were carried (not placed afresh).
    pub fn carried(&self) -> usize {
        self.carried
    }

    /// The previous frame's labels carried to `dots`, or `None` where they cannot be carried
    /// safely: another number of blobs, a blob that is not the mutual nearest neighbour of one
    /// previous blob within [`TRACK_FRACTION`] of that blob's nearest-neighbour distance, or (a
    /// safety net) a labelling whose reprojection RMS exceeds twice the previous frame's plus 0.1 px.
    ///
    /// Where every blob moved less than the fraction of its nearest-neighbour distance `d`, the
    /// true partner of a blob lies within `0.3 d` and any other previous blob at least `0.7 d`
    /// away, so the mutual nearest neighbours are the true pairs.
    pub fn carry(&self, dots: &[Dot], path: &SPath) -> Option<Vec<IndexedDot>> {
        if self.blobs.len() != dots.len() || dots.len() < 2 {
            return None;
        }
        let nearest =
            |p: &Point2<f64>, set: &mut dyn Iterator<Item = Point2<f64>>| set.enumerate().map(|(k, q)| (k, (q - p).norm())).min_by(|a, b| a.1.total_cmp(&b.1));
        let mut labels = Labels::new();
        for (i, (p, label)) in self.blobs.iter().enumerate() {
            let spacing = nearest(p, &mut self.blobs.iter().enumerate().filter(|(k, _)| *k != i).map(|(_, b)| b.0))?.1;
            let (j, moved) = nearest(p, &mut dots.iter().map(|d| d.centre_px))?;
            let back = nearest(&dots[j].centre_px, &mut self.blobs.iter().map(|b| b.0))?.0;
            if back != i || moved > TRACK_FRACTION * spacing {
                return None;
            }
            labels.extend(label.map(|l| (l, j)));
        }
        labels.sort_unstable();
        let (world, image) = correspondences(&labels, dots, path);
        let rms = Dlt::fit(&world, &image, None)?.rms(&world, &image);
        (rms <= RMS_GROWTH * self.rms_px + RMS_SLACK_PX).then(|| indexed(dots, &labels))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s_path_fit::{index_s_path, SPathFitParams};
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use synthcam_core::target::spherical_s;

    /// The course S-path's dots seen from the course's desired pose turned by `yaw` radians about
    /// the optical axis and moved `shift_px` along x (f = 1500 px).
    fn frame(yaw: f64, shift_px: f64) -> (SPath, Vec<Dot>) {
        let path = spherical_s();
        let r = nalgebra::Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, 1.0, -1.0, 0.0, 0.0));
        let turn = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
        let cam_from_world = Isometry3::from_parts(Translation3::new(0.0, -0.55, 1.8), turn * UnitQuaternion::from_rotation_matrix(&r));
        let dots = path
            .points_m
            .iter()
            .enumerate()
            .map(|(i, x)| {
                let c = cam_from_world * x;
                let area = if i == 0 { 83.0 } else { 30.0 };
                let centre_px = Point2::new(640.0 + shift_px + 1500.0 * c.x / c.z, 512.0 + 1500.0 * c.y / c.z);
                Dot { centre_px, area_px: area, spread_px: 1.5, core_px: 4, contrast: 200.0, touching: false }
            })
            .collect();
        (path, dots)
    }

    #[test]
    fn labels_are_carried_to_a_frame_that_moved_a_little_and_match_a_fresh_placement() {
        let (path, first) = frame(0.0, 0.0);
        let mut track = SPathTrack::default();
        assert!(track.carry(&first, &path).is_none(), "nothing to carry from");
        let placed = index_s_path(&first, &path, &SPathFitParams::default()).unwrap();
        track.remember(&first, &placed, &path, false);
        // Turned 0.3 degrees and moved 2 px (dots ~20 px apart), the dots given in another order.
        let (_, mut next) = frame(0.3f64.to_radians(), 2.0);
        next.reverse();
        let carried = track.carry(&next, &path).expect("carried");
        let fresh = index_s_path(&next, &path, &SPathFitParams::default()).unwrap();
        assert_eq!(carried, fresh);
    }

    #[test]
    fn labels_are_not_carried_where_the_pairing_is_unsafe() {
        let (path, first) = frame(0.0, 0.0);
        let mut track = SPathTrack::default();
        track.remember(&first, &index_s_path(&first, &path, &SPathFitParams::default()).unwrap(), &path, false);
        // A dot fewer.
        assert!(track.carry(&first[1..], &path).is_none());
        // Moved 12 px, more than 0.3 of the spacing.
        assert!(track.carry(&frame(0.0, 12.0).1, &path).is_none());
        // Every dot moved onto its neighbour's place (the S one index along itself): most blobs
        // pair at distance 0, but the path's first dot has moved a whole spacing. Refused.
        let mut along: Vec<Dot> = first.clone();
        for i in 0..100 {
            along[i].centre_px = first[i + 1].centre_px;
        }
        along[100].centre_px = first[100].centre_px + (first[100].centre_px - first[99].centre_px);
        assert!(track.carry(&along, &path).is_none());
        // A failed frame forgets the sequence.
        track.remember(&first, &[], &path, false);
        assert_eq!(track, SPathTrack::default());
    }
}
