//! Flat background tiles: the tiles whose pixels all see one texel value of the background
//! image, found on the CPU so that the background pass skips them (as `flat` does for the
//! target). Conservative: the texel box the tile's corner rays reach, grown by a quarter of its
//! size and a texel (the pixels' footprints at the tile's edge, the mapping's curvature), must
//! hold a single value, by a min / max pyramid of the image.

use rayon::prelude::*;

use super::flat::Cover;
use super::tiles::TileCornerRays;
use synthcam_core::mesh::Texture;
use synthcam_scene::background::{Background, Placement};

/// Per level `k`, the min and max of each `2^k x 2^k` block of texels.
#[derive(Debug)]
pub(super) struct MinMaxPyramid {
    levels: Vec<(usize, usize, Vec<[f32; 2]>)>,
}

impl MinMaxPyramid {
    pub(super) fn new(t: &Texture) -> Self {
        let (w, h) = (t.width as usize, t.height as usize);
        let mut levels = vec![(w, h, t.texels.iter().map(|v| [*v, *v]).collect::<Vec<_>>())];
        while let Some((pw, ph, prev)) = levels.last().filter(|(pw, ph, _)| *pw > 1 || *ph > 1) {
            let (nw, nh) = (pw.div_ceil(2), ph.div_ceil(2));
            let cells = (0..nw * nh)
                .into_par_iter()
                .map(|k| {
                    let (i, j) = (2 * (k % nw), 2 * (k / nw));
                    let mut r = [f32::INFINITY, f32::NEG_INFINITY];
                    for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        if i + di < *pw && j + dj < *ph {
                            let c = prev[(j + dj) * pw + i + di];
                            r = [r[0].min(c[0]), r[1].max(c[1])];
                        }
                    }
                    r
                })
                .collect();
            levels.push((nw, nh, cells));
        }
        Self { levels }
    }

    /// Min and max over texels `i0..=i1` x `j0..=j1` (within the image), or a superset of them.
    fn range(&self, [i0, j0]: [usize; 2], [i1, j1]: [usize; 2]) -> [f32; 2] {
        let k = (0..self.levels.len()).find(|k| (i1 >> k) - (i0 >> k) <= 1 && (j1 >> k) - (j0 >> k) <= 1).unwrap_or(self.levels.len() - 1);
        let (w, _, cells) = &self.levels[k];
        let mut r = [f32::INFINITY, f32::NEG_INFINITY];
        for j in (j0 >> k)..=(j1 >> k) {
            for i in (i0 >> k)..=(i1 >> k) {
                let c = cells[j * w + i];
                r = [r[0].min(c[0]), r[1].max(c[1])];
            }
        }
        r
    }

    /// The one value over the texel box `lo..hi` (a panorama's columns wrap), if it is one.
    fn flat_over(&self, lo: [f64; 2], hi: [f64; 2], wraps: bool) -> Option<f32> {
        let (w, h, _) = self.levels[0];
        let (wf, hf) = (w as f64, h as f64);
        let rows = [lo[1].clamp(0.0, hf - 1.0) as usize, hi[1].clamp(0.0, hf - 1.0) as usize];
        let spans: Vec<[f64; 2]> = if !wraps {
            if lo[0] < 0.0 || hi[0] >= wf || lo[1] < 0.0 || hi[1] >= hf {
                return None;
            }
            vec![[lo[0], hi[0]]]
        } else if hi[0] - lo[0] >= wf {
            return None;
        } else {
            let a = lo[0].rem_euclid(wf);
            let b = a + (hi[0] - lo[0]);
            if b < wf {
                vec![[a, b]]
            } else {
                vec![[a, wf - 1.0], [0.0, b - wf]]
            }
        };
        let mut r = [f32::INFINITY, f32::NEG_INFINITY];
        for [a, b] in spans {
            let q = self.range([a as usize, rows[0]], [(b as usize).min(w - 1), rows[1]]);
            r = [r[0].min(q[0]), r[1].max(q[1])];
        }
        (r[0] == r[1]).then_some(r[0])
    }
}

/// Per tile, the background's value where every pixel of the tile sees that one value (`None`:
/// the background pass computes the tile; tiles the sheet covers or the lens does not reach are
/// not tested).
pub(super) fn flat_background_tiles(
    bg: &Background,
    pyramid: &MinMaxPyramid,
    grid: &TileCornerRays,
    (tiles_x, tiles_y): (u32, u32),
    cover: &[Cover],
) -> Vec<Option<f32>> {
    let wraps = matches!(bg.placement, Placement::Panorama { .. });
    let w = f64::from(bg.texture.width);
    (0..tiles_x * tiles_y)
        .into_par_iter()
        .map(|t| {
            if matches!(cover.get(t as usize), Some(Cover::Inside | Cover::Beyond)) {
                return None;
            }
            let rays = grid.tile(t % tiles_x, t / tiles_x)?;
            let st = rays.iter().map(|d| bg.texel_along(d)).collect::<Option<Vec<_>>>()?;
            // Near a pole a panorama's columns converge: its longitudes need not bound the tile.
            if wraps && rays.iter().any(|d| pole_near(bg, d)) {
                return None;
            }
            // Columns relative to the first corner's, unwrapped across a panorama's seam.
            let unwrap = |s: f64| if wraps { st[0][0] + (s - st[0][0] + 0.5 * w).rem_euclid(w) - 0.5 * w } else { s };
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in &st {
                let q = [unwrap(p[0]), p[1]];
                lo = [lo[0].min(q[0]), lo[1].min(q[1])];
                hi = [hi[0].max(q[0]), hi[1].max(q[1])];
            }
            let grow = [0.25 * (hi[0] - lo[0]) + 1.0, 0.25 * (hi[1] - lo[1]) + 1.0];
            pyramid.flat_over([lo[0] - grow[0], lo[1] - grow[1]], [hi[0] + grow[0], hi[1] + grow[1]], wraps)
        })
        .collect()
}

/// Whether direction `d` (camera frame) is within 5 degrees of a panorama's pole.
fn pole_near(bg: &Background, d: &nalgebra::Vector3<f64>) -> bool {
    let Placement::Panorama { cam_from_pano } = bg.placement else { return false };
    let e = cam_from_pano.inverse() * d;
    e.y.abs() > 5f64.to_radians().cos() * e.norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pyramid_finds_one_value_only_where_the_box_holds_one() {
        // 8 x 4: left half 10, right half 20, one texel of 30 at (1, 3).
        let mut texels: Vec<f32> = (0..32).map(|i| if i % 8 < 4 { 10.0 } else { 20.0 }).collect();
        texels[3 * 8 + 1] = 30.0;
        let p = MinMaxPyramid::new(&Texture { width: 8, height: 4, texels });
        assert_eq!(p.flat_over([0.0, 0.0], [3.5, 1.5], false), Some(10.0));
        // Conservative: rows 0..=2 are read as the 2 x 2 blocks holding them, row 3's 30 included.
        assert_eq!(p.flat_over([0.0, 0.0], [3.5, 2.5], false), None);
        assert_eq!(p.flat_over([4.2, 0.0], [7.5, 3.5], false), Some(20.0));
        assert_eq!(p.flat_over([0.0, 2.0], [2.0, 3.5], false), None, "the 30 texel");
        assert_eq!(p.flat_over([3.0, 0.0], [4.5, 1.0], false), None, "the split");
        // A panorama's box across the seam takes both ends of the rows.
        assert_eq!(p.flat_over([-0.5, 0.0], [0.5, 1.0], true), None);
        assert_eq!(p.flat_over([-0.5, 0.0], [0.5, 1.0], false), None, "beyond a plane image");
        assert_eq!(p.flat_over([8.5, 0.0], [9.5, 1.0], true), Some(10.0), "wrapped to the first column");
    }
}
