//! Meshes the project makes itself (a geodesic sphere, boxes, a gripper, a calibration cube), a chessboard texture, and the
//! writers of OBJ/MTL text and PNG bytes of the files under `assets/meshes/` ([`assets`]; `--example make_meshes` rewrites them).
//!
//! Every mesh is centred on its own frame's origin, in metres, with outward counter-clockwise
//! triangles. Boxes are axis-aligned; a box face's texture is upright seen from outside, "up"
//! being +z on the four side faces (normals ±x, ±y) and +y on the two faces of normal ±z.
//! Only exact arithmetic and square roots are used, so the files are the same on every platform.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::sync::Arc;

use image::ImageEncoder;
use nalgebra::{Point3, Vector3};

use super::{Mesh, MeshError, Texture, Triangle};

/// Grey level of the dark squares of [`board_texture`].
pub const BOARD_DARK: f32 = 30.0;
/// Grey level of the light squares of [`board_texture`].
pub const BOARD_LIGHT: f32 = 220.0;

/// The icosahedron on the golden-ratio rectangles: 12 vertices, 20 outward CCW faces.
fn icosahedron() -> ([Vector3<f64>; 12], [[u32; 3]; 20]) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    #[rustfmt::skip]
    let v = [
        [-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0], [0.0, -1.0, t], [0.0, 1.0, t],
        [0.0, -1.0, -t], [0.0, 1.0, -t], [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0],
    ];
    #[rustfmt::skip]
    let faces = [
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    (v.map(Vector3::from), faces)
}

/// A class-I geodesic sphere of radius `radius_m`: each icosahedron face split into
/// `frequency^2` triangles (`frequency` 0 counts as 1), so `20 frequency^2` triangles on
/// `10 frequency^2 + 2` shared vertices, all on the sphere. Untextured, no albedo.
pub fn icosphere(radius_m: f64, frequency: u32) -> Mesh {
    let f = frequency.max(1);
    let (corners, faces) = icosahedron();
    // A lattice point is (weights on icosahedron vertices) / f; its key lists the non-zero
    // weights by vertex, so the points of an edge (or a corner) are the same for both faces.
    let mut index: HashMap<[(u32, u32); 3], u32> = HashMap::new();
    let mut positions_m = Vec::new();
    let mut triangles = Vec::with_capacity(20 * f as usize * f as usize);
    for face in faces {
        let mut id = |i: u32, j: u32| -> u32 {
            let mut key = [(face[0], f - i - j), (face[1], i), (face[2], j)].map(|(v, w)| if w == 0 { (u32::MAX, 0) } else { (v, w) });
            key.sort_unstable();
            *index.entry(key).or_insert_with(|| {
                let dir = key.iter().filter(|(_, w)| *w > 0).fold(Vector3::zeros(), |acc, &(v, w)| acc + corners[v as usize] * f64::from(w));
                positions_m.push(Point3::from(dir / dir.norm() * radius_m));
                (positions_m.len() - 1) as u32
            })
        };
        for j in 0..f {
            for i in 0..f - j {
                triangles.push(Triangle { v: [id(i, j), id(i + 1, j), id(i, j + 1)], uv: None, albedo: None });
                if i + j + 1 < f {
                    triangles.push(Triangle { v: [id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)], uv: None, albedo: None });
                }
            }
        }
    }
    Mesh { name: "icosphere".into(), positions_m, triangles, texture: None }
}

/// Texture coordinates of a box face's corners: bottom-left, bottom-right, top-right, top-left.
const FACE_UV: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

/// Append an axis-aligned box of size `size_m` centred at `centre_m`: 4 vertices and 2
/// triangles per face, faces in the order of outward normals -x, -y, -z, +x, +y, +z, each drawn
/// as `look(normal)` says: `(textured, albedo)`, a textured face showing the whole texture.
fn push_box(mesh: &mut Mesh, centre_m: Vector3<f64>, size_m: [f64; 3], look: impl Fn(Vector3<f64>) -> (bool, Option<f32>)) {
    let half = Vector3::from(size_m) / 2.0;
    let extent = |d: &Vector3<f64>| d.abs().dot(&half);
    for (axis, sign) in [(0, -1.0), (1, -1.0), (2, -1.0), (0, 1.0), (1, 1.0), (2, 1.0)] {
        let mut n = Vector3::zeros();
        n[axis] = sign;
        let up = if axis == 2 { Vector3::y() } else { Vector3::z() };
        let right = up.cross(&n);
        let c = centre_m + n * extent(&n);
        let (r, u) = (right * extent(&right), up * extent(&up));
        let base = mesh.positions_m.len() as u32;
        mesh.positions_m.extend([c - r - u, c + r - u, c + r + u, c - r + u].map(Point3::from));
        let (textured, albedo) = look(n);
        for tri in [[0, 1, 2], [0, 2, 3]] {
            mesh.triangles.push(Triangle { v: tri.map(|k| base + k), uv: textured.then_some(tri.map(|k| FACE_UV[k as usize])), albedo });
        }
    }
}

/// A box of size `size_m` (x, y, z) whose six faces each show the whole `texture`, upright seen
/// from outside (see the module notes); 12 triangles, no albedo.
pub fn textured_box(size_m: [f64; 3], texture: Arc<Texture>) -> Mesh {
    let mut mesh = Mesh { name: "textured_box".into(), positions_m: Vec::new(), triangles: Vec::new(), texture: Some(texture) };
    push_box(&mut mesh, Vector3::zeros(), size_m, |_| (true, None));
    mesh
}

/// A parallel two-finger gripper of three untextured boxes, 36 triangles: the palm (0.08 x 0.03
/// x 0.02 m, albedo 90) centred on the origin, and two fingers (0.012 x 0.015 x 0.06 m, albedo
/// 60) standing on the palm's +z face, their inner faces 0.04 m apart (centres at x = ±0.026 m),
/// reaching z = 0.07 m.
pub fn gripper() -> Mesh {
    let mut mesh = Mesh { name: "gripper".into(), positions_m: Vec::new(), triangles: Vec::new(), texture: None };
    push_box(&mut mesh, Vector3::zeros(), [0.08, 0.03, 0.02], |_| (false, Some(90.0)));
    for x in [-0.026, 0.026] {
        push_box(&mut mesh, Vector3::new(x, 0.0, 0.04), [0.012, 0.015, 0.06], |_| (false, Some(60.0)));
    }
    mesh
}

/// A cube of edge `edge_m` whose three faces of outward normals -x, -y and -z show a
/// `squares` x `squares` chessboard ([`board_texture`], the whole texture on each face, upright
/// as in the module notes); the faces +x, +y, +z are untextured with albedo 128. A camera on the
/// -z side looking along +z, moved a little towards -x and -y, sees the three boards. 12
/// triangles, the 6 textured ones first.
pub fn calibration_cube(edge_m: f64, squares: u32, texels_per_square: u32) -> Mesh {
    let texture = Arc::new(board_texture(squares, texels_per_square));
    let mut mesh = Mesh { name: "calibration_cube".into(), positions_m: Vec::new(), triangles: Vec::new(), texture: Some(texture) };
    push_box(&mut mesh, Vector3::zeros(), [edge_m; 3], |n| {
        let textured = n.sum() < 0.0;
        (textured, (!textured).then_some(128.0))
    });
    mesh
}

/// A margin-free chessboard of `squares` x `squares` squares (0 counts as 1) of
/// `texels_per_square` texels each (0 counts as 1): dark ([`BOARD_DARK`]) in the top-left corner,
/// light ([`BOARD_LIGHT`]) next to it.
pub fn board_texture(squares: u32, texels_per_square: u32) -> Texture {
    let (s, k) = (squares.max(1), texels_per_square.max(1));
    let n = s * k;
    let texels = (0..n * n).map(|t| if ((t % n) / k + (t / n) / k) % 2 == 0 { BOARD_DARK } else { BOARD_LIGHT }).collect();
    Texture { width: n, height: n, texels }
}

/// Append `args` to `out` (writing to a `String` cannot fail).
fn put(out: &mut String, args: std::fmt::Arguments) {
    let _ = out.write_fmt(args);
}

/// The material of a triangle in [`to_obj`]: (textured, albedo bits).
type MaterialKey = (bool, Option<u32>);

fn material_name((textured, albedo): MaterialKey) -> String {
    match albedo.map(|a| format!("grey_{}", f32::from_bits(a))) {
        Some(grey) if textured => format!("textured_{grey}"),
        Some(grey) => grey,
        None => if textured { "textured" } else { "untextured" }.into(),
    }
}

/// The Wavefront OBJ text of `mesh` and the text of its MTL file (saved as `mtl_file`, next to
/// the OBJ): positions (metres, 9 decimals), texture coordinates of the textured triangles
/// (shortest exact f32 form), and triangles grouped by material, one material per distinct
/// (textured, albedo): `Kd` = albedo / 255 grey, `map_Kd texture_file` when textured and
/// `texture_file` is given. Triangles without texture nor albedo come first, without material.
/// Groups keep the order in which their first triangle appears, so a mesh whose materials are
/// contiguous loads back ([`super::obj::load_obj`]) in the same triangle order.
pub fn to_obj(mesh: &Mesh, mtl_file: &str, texture_file: Option<&str>) -> (String, String) {
    let key = |t: &Triangle| -> MaterialKey { (t.uv.is_some(), t.albedo.map(f32::to_bits)) };
    let mut groups: Vec<MaterialKey> = Vec::new();
    for t in &mesh.triangles {
        if !groups.contains(&key(t)) {
            groups.push(key(t));
        }
    }
    groups.sort_by_key(|g| *g != (false, None));
    let (mut obj, mut mtl) = (String::new(), String::new());
    put(&mut obj, format_args!("# {}: {} triangles, metres (synthcam::mesh::primitives::to_obj)\n", mesh.name, mesh.triangles.len()));
    put(&mut obj, format_args!("mtllib {mtl_file}\no {}\n", mesh.name));
    for p in &mesh.positions_m {
        put(&mut obj, format_args!("v {:.9} {:.9} {:.9}\n", p.x, p.y, p.z));
    }
    let mut vt: HashMap<[u32; 2], usize> = HashMap::new();
    for uv in mesh.triangles.iter().filter_map(|t| t.uv).flatten() {
        let n = vt.len() + 1;
        vt.entry(uv.map(f32::to_bits)).or_insert_with(|| {
            put(&mut obj, format_args!("vt {} {}\n", uv[0], uv[1]));
            n
        });
    }
    for g in groups {
        if g != (false, None) {
            put(&mut obj, format_args!("usemtl {}\n", material_name(g)));
            put(&mut mtl, format_args!("newmtl {}\n", material_name(g)));
            if let Some(a) = g.1 {
                put(&mut mtl, format_args!("Kd {0:.9} {0:.9} {0:.9}\n", f64::from(f32::from_bits(a)) / 255.0));
            }
            if let (true, Some(file)) = (g.0, texture_file) {
                put(&mut mtl, format_args!("map_Kd {file}\n"));
            }
        }
        for t in mesh.triangles.iter().filter(|t| key(t) == g) {
            let [a, b, c] = t.v.map(|k| k + 1);
            match t.uv.map(|uv| uv.map(|p| vt[&p.map(f32::to_bits)])) {
                Some([ta, tb, tc]) => put(&mut obj, format_args!("f {a}/{ta} {b}/{tb} {c}/{tc}\n")),
                None => put(&mut obj, format_args!("f {a} {b} {c}\n")),
            }
        }
    }
    (obj, mtl)
}

/// The 8-bit grey PNG of `texture` (levels rounded and clamped to 0..255).
///
/// # Errors
/// [`MeshError::Texture`] when the texture has a zero dimension or fewer texels than
/// `width x height` (PNG cannot hold it).
pub fn texture_png(texture: &Texture) -> Result<Vec<u8>, MeshError> {
    let levels: Vec<u8> = texture.texels.iter().map(|v| v.round().clamp(0.0, 255.0) as u8).collect();
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&levels, texture.width, texture.height, image::ExtendedColorType::L8)
        .map_err(|source| MeshError::Texture { path: "(in memory)".into(), source })?;
    Ok(out)
}

/// A mesh of the project's committed assets (`assets/meshes/`), with its file stem.
#[derive(Debug, Clone)]
pub struct AssetFiles {
    /// File stem: the asset is `<stem>.obj`, `<stem>.mtl` and, when textured, `<stem>.png`.
    pub stem: &'static str,
    /// The mesh.
    pub mesh: Mesh,
}

impl AssetFiles {
    /// The asset's files, `(file name, bytes)`: OBJ, MTL and, when textured, PNG.
    ///
    /// # Errors
    /// As [`texture_png`].
    pub fn files(&self) -> Result<Vec<(String, Vec<u8>)>, MeshError> {
        let (obj, mtl, png) = (format!("{}.obj", self.stem), format!("{}.mtl", self.stem), format!("{}.png", self.stem));
        let (obj_text, mtl_text) = to_obj(&self.mesh, &mtl, self.mesh.texture.as_ref().map(|_| png.as_str()));
        let mut out = vec![(obj, obj_text.into_bytes()), (mtl, mtl_text.into_bytes())];
        if let Some(t) = &self.mesh.texture {
            out.push((png, texture_png(t)?));
        }
        Ok(out)
    }
}

/// The committed mesh assets: `icosphere` (radius 0.05 m, frequency 32, albedo 180), `gripper`,
/// `calibration_cube` (edge 0.1 m, 6 squares of 32 texels), `textured_box` (0.08 x 0.06 x 0.04 m,
/// [`board_texture`]`(4, 16)`).
pub fn assets() -> Vec<AssetFiles> {
    let mut sphere = icosphere(0.05, 32);
    sphere.triangles.iter_mut().for_each(|t| t.albedo = Some(180.0));
    vec![
        AssetFiles { stem: "icosphere", mesh: sphere },
        AssetFiles { stem: "gripper", mesh: gripper() },
        AssetFiles { stem: "calibration_cube", mesh: calibration_cube(0.1, 6, 32) },
        AssetFiles { stem: "textured_box", mesh: textured_box([0.08, 0.06, 0.04], Arc::new(board_texture(4, 16))) },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `(file, contents)` of files under `assets/meshes/`.
    macro_rules! committed {
        ($how:ident: $($file:literal),*) => { [$(($file, $how!(concat!("../../../../assets/meshes/", $file)))),*] };
    }
    /// The committed text files of [`assets`].
    const COMMITTED_TEXT: [(&str, &str); 8] = committed!(include_str: "icosphere.obj", "icosphere.mtl", "gripper.obj", "gripper.mtl", "calibration_cube.obj",
        "calibration_cube.mtl", "textured_box.obj", "textured_box.mtl");
    /// The committed textures of [`assets`].
    const COMMITTED_PNG: [(&str, &[u8]); 2] = committed!(include_bytes: "calibration_cube.png", "textured_box.png");

    fn normal(mesh: &Mesh, i: usize) -> Vector3<f64> {
        let [a, b, c] = mesh.corners_m(i);
        (b - a).cross(&(c - a))
    }

    fn centroid(mesh: &Mesh, i: usize) -> Vector3<f64> {
        mesh.corners_m(i).iter().map(|p| p.coords).sum::<Vector3<f64>>() / 3.0
    }

    fn assert_same_texture(a: &Texture, b: &Texture) {
        assert_eq!((a.width, a.height), (b.width, b.height));
        assert!(a.texels.iter().zip(&b.texels).all(|(x, y)| (x - y).abs() < 1e-3));
    }

    #[test]
    fn icosphere_is_a_closed_outward_sphere_of_20_f2_triangles() {
        for (f, n) in [(0, 20), (1, 20), (2, 80), (3, 180), (32, 20480)] {
            let m = icosphere(0.05, f);
            assert_eq!((m.triangles.len(), m.positions_m.len()), (n, n / 2 + 2), "frequency {f}");
            assert!(m.positions_m.iter().all(|p| (p.coords.norm() - 0.05).abs() <= 0.05 * 1e-12));
            // Every directed edge once and its reverse once: closed, consistently wound.
            let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
            for t in &m.triangles {
                for k in 0..3 {
                    *edges.entry((t.v[k], t.v[(k + 1) % 3])).or_default() += 1;
                }
            }
            assert!(edges.iter().all(|(&(a, b), &c)| c == 1 && edges.get(&(b, a)) == Some(&1)), "frequency {f}");
            assert!((0..n).all(|i| normal(&m, i).dot(&centroid(&m, i)) > 0.0), "frequency {f}");
            assert!(m.validate().is_ok() && m.triangles.iter().all(|t| t.uv.is_none() && t.albedo.is_none()));
        }
    }

    #[test]
    fn textured_box_faces_show_the_whole_texture_upright() {
        let m = textured_box([0.08, 0.06, 0.04], Arc::new(board_texture(4, 16)));
        assert_eq!(m.triangles.len(), 12);
        assert_eq!(m.bounds_m(), (Point3::new(-0.04, -0.03, -0.02), Point3::new(0.04, 0.03, 0.02)));
        for (i, t) in m.triangles.iter().enumerate() {
            let n = normal(&m, i).normalize();
            assert!(n.dot(&centroid(&m, i)) > 0.0, "triangle {i} faces inward");
            let up = if n.z.abs() > 0.5 { Vector3::y() } else { Vector3::z() };
            let (right, uv, p) = (up.cross(&n), t.uv.unwrap(), m.corners_m(i));
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                let d = p[a] - p[b];
                assert!(d.dot(&right) * f64::from(uv[a][0] - uv[b][0]) >= 0.0 && d.dot(&up) * f64::from(uv[a][1] - uv[b][1]) >= 0.0, "triangle {i}");
            }
        }
        for face in m.triangles.chunks(2) {
            let corners: Vec<[f32; 2]> = face.iter().flat_map(|t| t.uv.unwrap()).collect();
            assert!(FACE_UV.iter().all(|c| corners.contains(c)));
        }
    }

    #[test]
    fn gripper_is_a_palm_and_two_fingers() {
        let m = gripper();
        assert_eq!(m.triangles.len(), 36);
        let (lo, hi) = m.bounds_m();
        assert!((lo - Point3::new(-0.04, -0.015, -0.01)).norm() < 1e-15 && (hi - Point3::new(0.04, 0.015, 0.07)).norm() < 1e-15);
        let centres = [Vector3::zeros(), Vector3::new(-0.026, 0.0, 0.04), Vector3::new(0.026, 0.0, 0.04)];
        for (i, t) in m.triangles.iter().enumerate() {
            assert_eq!((t.albedo, t.uv), (Some(if i < 12 { 90.0 } else { 60.0 }), None));
            assert!(normal(&m, i).dot(&(centroid(&m, i) - centres[i / 12])) > 0.0, "triangle {i} faces inward");
        }
        let inner_gap = m.positions_m[48..].iter().map(|p| p.x).fold(f64::INFINITY, f64::min) - m.positions_m[24..48].iter().map(|p| p.x).fold(-1.0, f64::max);
        assert!((inner_gap - 0.04).abs() < 1e-15, "{inner_gap}");
    }

    #[test]
    fn calibration_cube_has_boards_on_its_negative_faces() {
        let m = calibration_cube(0.1, 6, 32);
        assert_eq!(m.triangles.len(), 12);
        assert_eq!(m.bounds_m(), (Point3::new(-0.05, -0.05, -0.05), Point3::new(0.05, 0.05, 0.05)));
        assert_same_texture(m.texture.as_ref().unwrap(), &board_texture(6, 32));
        for (i, t) in m.triangles.iter().enumerate() {
            let n = normal(&m, i);
            assert!(n.dot(&centroid(&m, i)) > 0.0, "triangle {i} faces inward");
            assert_eq!((t.uv.is_some(), t.albedo, n.sum() < 0.0), (i < 6, (i >= 6).then_some(128.0), i < 6), "triangle {i}");
        }
    }

    #[test]
    fn board_texture_is_a_chessboard_with_a_dark_top_left_square() {
        let t = board_texture(2, 3);
        assert_eq!((t.width, t.height), (6, 6));
        let at = |i: u32, j: u32| t.texels[(j * 6 + i) as usize];
        assert_eq!([at(0, 0), at(2, 2), at(3, 0), at(0, 3), at(3, 3), at(5, 5)], [30.0, 30.0, 220.0, 220.0, 30.0, 30.0]);
        assert_eq!(board_texture(0, 0).texels, vec![BOARD_DARK]);
    }

    #[test]
    fn texture_png_decodes_to_the_texture() {
        let t = board_texture(3, 5);
        let img = image::load_from_memory(&texture_png(&t).unwrap()).unwrap();
        assert_eq!(img.color(), image::ColorType::L8);
        assert_same_texture(&Texture::from_image(&img), &t);
    }

    #[test]
    fn assets_match_the_generators() {
        let regen = "regenerate with `cargo run --release --example make_meshes` if the change is intended";
        let mut seen = 0;
        for asset in assets() {
            for (file, bytes) in asset.files().unwrap() {
                seen += 1;
                if let Some((_, png)) = COMMITTED_PNG.iter().find(|(f, _)| *f == file) {
                    let committed = Texture::from_image(&image::load_from_memory(png).unwrap());
                    assert_same_texture(&committed, asset.mesh.texture.as_ref().unwrap());
                    continue;
                }
                let Some((_, text)) = COMMITTED_TEXT.iter().find(|(f, _)| *f == file) else { panic!("assets/meshes/{file} is not committed") };
                let made = String::from_utf8(bytes).unwrap();
                if let Some((k, (a, b))) = text.lines().zip(made.lines()).enumerate().find(|(_, (a, b))| a != b) {
                    panic!("assets/meshes/{file} line {}: committed `{a}`, generated `{b}`: {regen}", k + 1);
                }
                assert!(*text == made, "assets/meshes/{file} differs in length from the generator: {regen}");
            }
        }
        assert_eq!(seen, COMMITTED_TEXT.len() + COMMITTED_PNG.len());
    }
}
