//! Exact areas of convex polygons clipped by axis-aligned rectangles and by discs (f64).
//!
//! The exact planar reference renderer (`synthcam_scene::exact`) measures how much of a pixel's
//! footprint on the target plane falls in each square, plate and disc with these.
//!
//! - Clipping: Sutherland & Hodgman, "Reentrant polygon clipping", CACM 17(1), 1974 (one
//!   half-plane at a time; a convex polygon stays convex).
//! - Area: the shoelace formula.
//! - Polygon and disc: the signed area of each edge's triangle (centre, a, b) intersected with the
//!   disc, summed over the edges; each triangle splits where its edge crosses the circle into
//!   straight pieces (triangles) and pieces outside the circle (circular sectors).
//!
//! Hand-written because these are a few lines each: `geo`'s boolean operations work on general
//! polygons but have no exact disc, and would pull a large dependency into the library.

use nalgebra::Vector2;

/// A convex polygon, vertices in order (either orientation).
pub type Polygon = Vec<Vector2<f64>>;

/// The part of `poly` where `dot(n, p) <= c`.
pub fn clip_halfplane(poly: &[Vector2<f64>], n: Vector2<f64>, c: f64) -> Polygon {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let da = n.dot(a) - c;
        let db = n.dot(&b) - c;
        if da <= 0.0 {
            out.push(*a);
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// The part of `poly` inside the rectangle `[lo.x, hi.x] x [lo.y, hi.y]`.
pub fn clip_rect(poly: &[Vector2<f64>], lo: Vector2<f64>, hi: Vector2<f64>) -> Polygon {
    let p = clip_halfplane(poly, Vector2::new(1.0, 0.0), hi.x);
    let p = clip_halfplane(&p, Vector2::new(-1.0, 0.0), -lo.x);
    let p = clip_halfplane(&p, Vector2::new(0.0, 1.0), hi.y);
    clip_halfplane(&p, Vector2::new(0.0, -1.0), -lo.y)
}

/// Area of a simple polygon (shoelace), non-negative.
pub fn area(poly: &[Vector2<f64>]) -> f64 {
    signed_area(poly).abs()
}

/// Signed area of a polygon (shoelace): positive for vertices in counter-clockwise order in a
/// y-up frame (clockwise on screen, y down).
pub fn signed_area(poly: &[Vector2<f64>]) -> f64 {
    let mut s = 0.0;
    for (i, a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        s += a.x * b.y - a.y * b.x;
    }
    0.5 * s
}

/// Axis-aligned bounding box `(lo, hi)` of a polygon; `None` when it is empty.
pub fn bbox(poly: &[Vector2<f64>]) -> Option<(Vector2<f64>, Vector2<f64>)> {
    let first = poly.first()?;
    Some(poly.iter().fold((*first, *first), |(lo, hi), p| (lo.inf(p), hi.sup(p))))
}

/// Area of the intersection of a simple polygon with the disc of `centre` and `radius`,
/// non-negative.
pub fn disc_area(poly: &[Vector2<f64>], centre: Vector2<f64>, radius: f64) -> f64 {
    let mut s = 0.0;
    for (i, a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        s += triangle_disc_signed(a - centre, b - centre, radius);
    }
    s.abs()
}

/// Signed area of the triangle (0, a, b) intersected with the disc of radius r about 0.
fn triangle_disc_signed(a: Vector2<f64>, b: Vector2<f64>, r: f64) -> f64 {
    let d = b - a;
    let qa = d.dot(&d);
    let mut cuts = [0.0, 1.0, 1.0, 1.0];
    let mut n = 1;
    if qa > 0.0 {
        let qb = 2.0 * a.dot(&d);
        let qc = a.dot(&a) - r * r;
        let disc = qb * qb - 4.0 * qa * qc;
        if disc > 0.0 {
            let sq = disc.sqrt();
            for t in [(-qb - sq) / (2.0 * qa), (-qb + sq) / (2.0 * qa)] {
                if t > 0.0 && t < 1.0 {
                    cuts[n] = t;
                    n += 1;
                }
            }
        }
    }
    cuts[n] = 1.0;
    let mut s = 0.0;
    for k in 0..n {
        let p = a + d * cuts[k];
        let q = a + d * cuts[k + 1];
        let mid = a + d * (0.5 * (cuts[k] + cuts[k + 1]));
        let cross = p.x * q.y - p.y * q.x;
        s += if mid.norm_squared() <= r * r { 0.5 * cross } else { 0.5 * r * r * cross.atan2(p.dot(&q)) };
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn square(c: f64, h: f64) -> Polygon {
        vec![Vector2::new(c - h, c - h), Vector2::new(c + h, c - h), Vector2::new(c + h, c + h), Vector2::new(c - h, c + h)]
    }

    #[test]
    fn rectangle_clip_of_a_rotated_square() {
        // A unit square rotated 45 degrees about the origin, clipped to x >= 0: half of it.
        let s = 0.5f64.sqrt();
        let diamond = vec![Vector2::new(s, 0.0), Vector2::new(0.0, s), Vector2::new(-s, 0.0), Vector2::new(0.0, -s)];
        let half = clip_rect(&diamond, Vector2::new(0.0, -1.0), Vector2::new(1.0, 1.0));
        assert!((area(&half) - 0.5).abs() < 1e-15);
        // The corner x, y >= 0: a quarter.
        let quarter = clip_rect(&diamond, Vector2::new(0.0, 0.0), Vector2::new(1.0, 1.0));
        assert!((area(&quarter) - 0.25).abs() < 1e-15);
        // Disjoint: nothing.
        assert_eq!(area(&clip_rect(&diamond, Vector2::new(2.0, 2.0), Vector2::new(3.0, 3.0))), 0.0);
    }

    #[test]
    fn disc_areas_against_closed_forms() {
        // Whole disc inside a large square.
        assert!((disc_area(&square(0.0, 10.0), Vector2::zeros(), 1.0) - PI).abs() < 1e-12);
        // Square inside the disc: the square.
        assert!((disc_area(&square(0.0, 0.5), Vector2::zeros(), 1.0) - 1.0).abs() < 1e-12);
        // The disc's quarter in the first quadrant.
        let q = vec![Vector2::new(0.0, 0.0), Vector2::new(5.0, 0.0), Vector2::new(5.0, 5.0), Vector2::new(0.0, 5.0)];
        assert!((disc_area(&q, Vector2::zeros(), 2.0) - PI).abs() < 1e-12);
        // Circular segment cut by the line x = 0.5 (r = 1): r^2 acos(d/r) - d sqrt(r^2 - d^2).
        let strip = vec![Vector2::new(0.5, -3.0), Vector2::new(3.0, -3.0), Vector2::new(3.0, 3.0), Vector2::new(0.5, 3.0)];
        let seg = (0.5f64).acos() - 0.5 * (0.75f64).sqrt();
        assert!((disc_area(&strip, Vector2::zeros(), 1.0) - seg).abs() < 1e-12);
        // Disjoint.
        assert!(disc_area(&square(5.0, 0.5), Vector2::zeros(), 1.0).abs() < 1e-15);
    }

    #[test]
    fn disc_area_converges_to_a_grid_count() {
        // A skewed quadrilateral across a disc's rim, against 2000 x 2000 point samples.
        let poly = vec![Vector2::new(0.6, -0.3), Vector2::new(1.4, -0.1), Vector2::new(1.2, 0.7), Vector2::new(0.5, 0.4)];
        let (c, r) = (Vector2::new(0.1, 0.05), 1.0);
        let n = 2000;
        let mut hits = 0usize;
        for j in 0..n {
            for i in 0..n {
                let p = Vector2::new(0.4 + 1.1 * (f64::from(i) + 0.5) / f64::from(n), -0.4 + 1.2 * (f64::from(j) + 0.5) / f64::from(n));
                let inside_poly = (0..4).all(|k| {
                    let a = poly[k];
                    let b = poly[(k + 1) % 4];
                    (b - a).perp(&(p - a)) >= 0.0
                });
                hits += usize::from(inside_poly && (p - c).norm() < r);
            }
        }
        let grid = hits as f64 * 1.1 * 1.2 / f64::from(n * n);
        assert!((disc_area(&poly, c, r) - grid).abs() < 2e-4, "{} vs {grid}", disc_area(&poly, c, r));
    }
}
