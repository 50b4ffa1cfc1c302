//! A grey albedo texture, piecewise constant over its texels, with per-row prefix sums so the
//! mean over any axis-aligned box (in texel units, fractional) is exact in O(rows): the box
//! filter the renderer applies over each sample's footprint, on the CPU and in the shader.
//!
//! Texel `(i, j)` (column, row from the *top* of the image) covers `[i, i+1] x [j, j+1]` in
//! texel coordinates `s = u * width`, `t = (1 - v) * height` (OBJ's `v` points up).

/// A grey texture (levels 0..255).
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    /// Width, texels.
    pub width: u32,
    /// Height, texels.
    pub height: u32,
    /// Grey levels, row-major, top row first.
    pub texels: Vec<f32>,
}

impl Texture {
    /// The texture of an image (its BT.601 luma for colour images, 16-bit scaled to 0..255).
    pub fn from_image(img: &image::DynamicImage) -> Self {
        let grey = img.to_luma32f();
        Self { width: grey.width(), height: grey.height(), texels: grey.as_raw().iter().map(|v| v * 255.0).collect() }
    }

    /// Texel coordinates of texture coordinates `uv`, clamped to the texture.
    pub fn texel_of(&self, uv: [f64; 2]) -> [f64; 2] {
        [uv[0].clamp(0.0, 1.0) * f64::from(self.width), (1.0 - uv[1].clamp(0.0, 1.0)) * f64::from(self.height)]
    }

    /// The texel holding texel coordinates `st` (nearest-texel point sample).
    pub fn at(&self, st: [f64; 2]) -> f64 {
        let i = (st[0].floor().max(0.0) as u32).min(self.width.saturating_sub(1));
        let j = (st[1].floor().max(0.0) as u32).min(self.height.saturating_sub(1));
        f64::from(self.texels[(j * self.width + i) as usize])
    }

    /// Per row, the prefix sums `S(k) = sum of texels 0..k` (`width + 1` entries per row, f32 as
    /// the shader reads them).
    pub fn row_prefix_sums(&self) -> Vec<f32> {
        let w = self.width as usize;
        let mut out = Vec::with_capacity((w + 1) * self.height as usize);
        for row in self.texels.chunks(w.max(1)) {
            let mut acc = 0.0f64;
            out.push(0.0);
            for v in row {
                acc += f64::from(*v);
                out.push(acc as f32);
            }
        }
        out
    }

    /// The exact mean of the texture over the box `lo..hi` (texel coordinates, clamped to the
    /// texture); a box narrower than `1e-6` texels along an axis is a line (its point values).
    pub fn box_mean(&self, lo: [f64; 2], hi: [f64; 2]) -> f64 {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        let (x0, x1) = (lo[0].clamp(0.0, w), hi[0].clamp(0.0, w));
        let (y0, y1) = (lo[1].clamp(0.0, h), hi[1].clamp(0.0, h));
        let row_mean = |j: usize| -> f64 {
            let row = &self.texels[j * self.width as usize..(j + 1) * self.width as usize];
            if x1 - x0 < 1e-6 {
                return f64::from(row[(x0.floor() as usize).min(row.len() - 1)]);
            }
            let mut acc = 0.0;
            for (i, v) in row.iter().enumerate().take(x1.ceil() as usize).skip(x0.floor() as usize) {
                let cover = (x1.min(i as f64 + 1.0) - x0.max(i as f64)).max(0.0);
                acc += cover * f64::from(*v);
            }
            acc / (x1 - x0)
        };
        if y1 - y0 < 1e-6 {
            return row_mean((y0.floor() as usize).min(self.height as usize - 1));
        }
        let mut acc = 0.0;
        for j in (y0.floor() as usize)..(y1.ceil() as usize).min(self.height as usize) {
            acc += (y1.min(j as f64 + 1.0) - y0.max(j as f64)).max(0.0) * row_mean(j);
        }
        acc / (y1 - y0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        // 4 x 2: top row 0 255 0 255, bottom row 255 0 255 0.
        Texture { width: 4, height: 2, texels: vec![0.0, 255.0, 0.0, 255.0, 255.0, 0.0, 255.0, 0.0] }
    }

    #[test]
    fn box_mean_matches_hand_integrals() {
        let t = checker();
        assert_eq!(t.box_mean([0.0, 0.0], [4.0, 2.0]), 127.5);
        // Half of texel (0,0) and half of (1,0): (0 + 255) / 2.
        assert!((t.box_mean([0.5, 0.0], [1.5, 1.0]) - 127.5).abs() < 1e-12);
        // A quarter box inside texel (1, 1) = 0.
        assert_eq!(t.box_mean([1.25, 1.25], [1.5, 1.5]), 0.0);
        // Line along y through column 1: rows 255 (top) and 0 weighted 0.75 / 0.25.
        assert!((t.box_mean([1.5, 0.25], [1.5, 1.25]) - (0.75 * 255.0)).abs() < 1e-9);
    }

    #[test]
    fn prefix_sums_end_in_row_totals() {
        let s = checker().row_prefix_sums();
        assert_eq!(s.len(), 10);
        assert_eq!(s[4], 510.0);
        assert_eq!(s[9], 510.0);
    }

    #[test]
    fn texel_of_flips_v_and_clamps() {
        let t = checker();
        assert_eq!(t.texel_of([0.25, 1.0]), [1.0, 0.0]);
        assert_eq!(t.texel_of([2.0, -1.0]), [4.0, 2.0]);
        assert_eq!(t.at([3.9, 1.9]), 0.0);
    }
}
