//! Wavefront OBJ loading with `tobj`: every object of the file concatenated into one [`Mesh`], a
//! grey albedo from each material's diffuse `Kd`, and at most one `map_Kd` texture per mesh.
//!
//! Files are read through the caller's `read` function (no file I/O in this module). The MTL
//! files (`mtllib`) and the texture images (`map_Kd`) are named relative to the OBJ's folder.
//!
//! Precision: positions, texture coordinates
//! and colours are parsed as f64 (tobj's `use_f64` feature); texture coordinates are kept as f32.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Point3;

use super::{is_degenerate, Mesh, MeshError, Texture, Triangle};

/// What loading found besides the mesh.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ObjReport {
    /// Degenerate triangles (a repeated vertex, or zero area by [`is_degenerate`]) left out.
    pub degenerate_skipped: usize,
}

/// The caller's file reader.
type ReadFn<'a> = &'a dyn Fn(&Path) -> std::io::Result<Vec<u8>>;

/// Load the OBJ file `path` (and its MTL files and texture) into one mesh named after `path`.
///
/// Faces are triangulated (points and lines ignored). A triangle gets texture coordinates when
/// its material has a `map_Kd` texture, and an albedo (BT.601 luma of `Kd`, x 255) when its
/// material has a diffuse colour. Degenerate triangles are skipped, counted in the report and
/// logged once.
///
/// # Errors
/// [`MeshError::Read`] when the OBJ, an MTL or the texture cannot be read (naming that file);
/// [`MeshError::Obj`] when the OBJ or an MTL does not parse (an index out of range included);
/// [`MeshError::Texture`] when the texture does not decode; [`MeshError::Invalid`] for a
/// non-finite vertex, a second texture, a textured material without texture coordinates, or no
/// triangle left.
pub fn load_obj(path: &Path, read: &dyn Fn(&Path) -> std::io::Result<Vec<u8>>) -> Result<(Mesh, ObjReport), MeshError> {
    let name = path.display().to_string();
    let bytes = read(path).map_err(|source| MeshError::Read { path: name.clone(), source })?;
    let dir = path.parent().unwrap_or_else(|| Path::new(""));
    let (models, materials) = parse(&name, &bytes, dir, read)?;
    let mut builder = Builder {
        mesh: Mesh { name, positions_m: Vec::new(), triangles: Vec::new(), texture: None },
        report: ObjReport::default(),
        dir,
        read,
        materials: &materials,
        texture_path: None,
    };
    for model in &models {
        builder.add_model(model)?;
    }
    builder.finish()
}

/// Parse the OBJ `bytes` and the MTL files it names; the first MTL failure wins over tobj's
/// own (which would only say that a material library failed).
fn parse(name: &str, bytes: &[u8], dir: &Path, read: ReadFn) -> Result<(Vec<tobj::Model>, Vec<tobj::Material>), MeshError> {
    let mtl_error: RefCell<Option<MeshError>> = RefCell::new(None);
    let load_mtl = |mtl: &Path| {
        let mtl_path = dir.join(mtl);
        let shown = mtl_path.display().to_string();
        let loaded = match read(&mtl_path) {
            Ok(text) => tobj::load_mtl_buf(&mut text.as_slice()).map_err(|source| MeshError::Obj { path: shown, source }),
            Err(source) => Err(MeshError::Read { path: shown, source }),
        };
        loaded.map_err(|e| {
            let code = if let MeshError::Obj { source, .. } = &e { *source } else { tobj::LoadError::OpenFileFailed };
            mtl_error.borrow_mut().get_or_insert(e);
            code
        })
    };
    // Triangulated, points and lines ignored; positions and texture coordinates indexed apart.
    let options = tobj::LoadOptions { single_index: false, ..tobj::GPU_LOAD_OPTIONS };
    let loaded = tobj::load_obj_buf(&mut &bytes[..], &options, load_mtl);
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    let obj_error = |source| MeshError::Obj { path: name.to_string(), source };
    let (models, materials) = loaded.map_err(obj_error)?;
    Ok((models, materials.map_err(obj_error)?))
}

/// The mesh under construction.
struct Builder<'a> {
    /// The mesh so far.
    mesh: Mesh,
    /// What was skipped so far.
    report: ObjReport,
    /// The OBJ's folder, which texture names are relative to.
    dir: &'a Path,
    /// The caller's reader.
    read: ReadFn<'a>,
    /// The materials of all MTL files.
    materials: &'a [tobj::Material],
    /// Where the mesh's texture came from, once loaded.
    texture_path: Option<PathBuf>,
}

impl Builder<'_> {
    fn invalid(&self, reason: String) -> MeshError {
        MeshError::Invalid { path: self.mesh.name.clone(), reason }
    }

    /// Append the vertices and the non-degenerate triangles of one tobj model (one object and
    /// material).
    fn add_model(&mut self, model: &tobj::Model) -> Result<(), MeshError> {
        let m = &model.mesh;
        let offset = self.mesh.positions_m.len();
        for (k, c) in m.positions.chunks_exact(3).enumerate() {
            let p = Point3::new(c[0], c[1], c[2]);
            if !p.coords.iter().all(|v| v.is_finite()) {
                return Err(self.invalid(format!("vertex {k} of object '{}' is not finite: ({}, {}, {})", model.name, p.x, p.y, p.z)));
            }
            self.mesh.positions_m.push(p);
        }
        let material = m.material_id.and_then(|i| self.materials.get(i));
        let albedo = material.and_then(|mat| mat.diffuse).map(|[r, g, b]| luma_255(r, g, b));
        let textured = match material.and_then(|mat| mat.diffuse_texture.as_deref()) {
            Some(file) => {
                self.use_texture(file)?;
                true
            }
            None => false,
        };
        if textured && (m.texcoords.is_empty() || m.texcoord_indices.len() != m.indices.len()) {
            let mat = material.map_or("", |mat| mat.name.as_str());
            return Err(self.invalid(format!("object '{}' has the textured material '{mat}' but no texture coordinates", model.name)));
        }
        let n_local = m.positions.len() / 3;
        for (f, idx) in m.indices.chunks_exact(3).enumerate() {
            if idx.iter().any(|&i| i as usize >= n_local) {
                return Err(self.invalid(format!("object '{}': face {f} indexes a vertex beyond its {n_local} vertices", model.name)));
            }
            let v = [0, 1, 2].map(|c| (offset + idx[c] as usize) as u32);
            let corners = v.map(|k| self.mesh.positions_m[k as usize]);
            if idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2] || is_degenerate(&corners) {
                self.report.degenerate_skipped += 1;
                continue;
            }
            let uv = if textured { Some(self.uv(model, f)?) } else { None };
            self.mesh.triangles.push(Triangle { v, uv, albedo });
        }
        Ok(())
    }

    /// The texture coordinates of face `f` of `model`.
    fn uv(&self, model: &tobj::Model, f: usize) -> Result<[[f32; 2]; 3], MeshError> {
        let m = &model.mesh;
        let mut out = [[0.0; 2]; 3];
        for (c, uv) in out.iter_mut().enumerate() {
            let t = m.texcoord_indices[3 * f + c] as usize;
            let (Some(&u), Some(&v)) = (m.texcoords.get(2 * t), m.texcoords.get(2 * t + 1)) else {
                return Err(self.invalid(format!("object '{}': face {f} indexes a texture coordinate out of range", model.name)));
            };
            *uv = [u as f32, v as f32];
        }
        Ok(out)
    }

    /// Make the image `file` (relative to the OBJ's folder) the mesh's texture, loading it the
    /// first time; a second, different image is an error.
    fn use_texture(&mut self, file: &str) -> Result<(), MeshError> {
        let path = self.dir.join(file);
        match &self.texture_path {
            Some(p) if *p == path => Ok(()),
            Some(p) => Err(self.invalid(format!("uses more than one texture ({} and {}); a mesh has at most one", p.display(), path.display()))),
            None => {
                let shown = path.display().to_string();
                let bytes = (self.read)(&path).map_err(|source| MeshError::Read { path: shown.clone(), source })?;
                let img = image::load_from_memory(&bytes).map_err(|source| MeshError::Texture { path: shown, source })?;
                self.mesh.texture = Some(Arc::new(Texture::from_image(&img)));
                self.texture_path = Some(path);
                Ok(())
            }
        }
    }

    fn finish(self) -> Result<(Mesh, ObjReport), MeshError> {
        if self.report.degenerate_skipped > 0 {
            log::warn!("{}: skipped {} degenerate triangle(s)", self.mesh.name, self.report.degenerate_skipped);
        }
        self.mesh.validate()?;
        Ok((self.mesh, self.report))
    }
}

/// BT.601 luma of a linear colour in [0, 1], times 255.
fn luma_255(r: f64, g: f64, b: f64) -> f32 {
    ((0.299 * r + 0.587 * g + 0.114 * b) * 255.0) as f32
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::mesh::primitives::{assets, gripper, icosphere, texture_png, to_obj};

    const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    const UVS: &str = "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";

    /// Load `path` from the in-memory files `files`.
    fn load(files: &[(&str, &[u8])], path: &str) -> Result<(Mesh, ObjReport), MeshError> {
        let map: HashMap<PathBuf, Vec<u8>> = files.iter().map(|(p, b)| (PathBuf::from(p), b.to_vec())).collect();
        let read = |p: &Path| map.get(p).cloned().ok_or_else(|| std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"));
        load_obj(Path::new(path), &read)
    }

    /// A 4 x 2 grey PNG: top row 0 85 170 255, bottom row 255 170 85 0.
    fn png() -> Vec<u8> {
        let img = image::GrayImage::from_raw(4, 2, vec![0, 85, 170, 255, 255, 170, 85, 0]).unwrap();
        let mut out = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
        out
    }

    fn textured_obj() -> String {
        format!("mtllib quad.mtl\n{QUAD}{UVS}usemtl tex\nf 1/1 2/2 3/3 4/4\n")
    }

    fn error_path(e: &MeshError) -> &str {
        match e {
            MeshError::Read { path, .. } | MeshError::Obj { path, .. } | MeshError::Texture { path, .. } | MeshError::Invalid { path, .. } => path,
        }
    }

    #[test]
    fn grey_quad_gets_the_kd_luma() {
        let obj = format!("mtllib quad.mtl\n{QUAD}usemtl grey\nf 1 2 3 4\n");
        let (mesh, report) = load(&[("m/quad.obj", obj.as_bytes()), ("m/quad.mtl", b"newmtl grey\nKd 0.5 0.5 0.5\n")], "m/quad.obj").unwrap();
        assert_eq!(mesh.name, "m/quad.obj");
        assert_eq!((mesh.triangles.len(), report.degenerate_skipped), (2, 0));
        assert!(mesh.texture.is_none());
        for t in &mesh.triangles {
            assert!((t.albedo.unwrap() - 127.5).abs() < 1e-4, "{t:?}");
            assert!(t.uv.is_none());
        }
        assert_eq!(mesh.bounds_m(), (Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 1.0, 0.0)));
    }

    #[test]
    fn textured_quad_gets_uv_and_the_texture() {
        let (obj, png) = (textured_obj(), png());
        let files: [(&str, &[u8]); 3] = [("m/quad.obj", obj.as_bytes()), ("m/quad.mtl", b"newmtl tex\nmap_Kd tex.png\n"), ("m/tex.png", &png)];
        let (mesh, _) = load(&files, "m/quad.obj").unwrap();
        let tex = mesh.texture.as_ref().unwrap();
        assert_eq!((tex.width, tex.height), (4, 2));
        assert!((tex.texels[1] - 85.0).abs() < 1e-3 && (tex.texels[4] - 255.0).abs() < 1e-3);
        assert_eq!(mesh.triangles.len(), 2);
        assert_eq!(mesh.triangles[0].uv, Some([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]));
        assert_eq!(mesh.triangles[1].uv, Some([[0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]));
        assert!(mesh.triangles.iter().all(|t| t.albedo.is_none()));
    }

    #[test]
    fn missing_files_are_read_errors_naming_the_file() {
        let e = load(&[], "m/none.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Read { path, .. } if path == "m/none.obj"), "{e}");
        let obj = format!("mtllib quad.mtl\n{QUAD}f 1 2 3\n");
        let e = load(&[("m/quad.obj", obj.as_bytes())], "m/quad.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Read { path, .. } if path == "m/quad.mtl"), "{e}");
        let obj = textured_obj();
        let e = load(&[("m/quad.obj", obj.as_bytes()), ("m/quad.mtl", b"newmtl tex\nmap_Kd tex.png\n")], "m/quad.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Read { path, .. } if path == "m/tex.png"), "{e}");
    }

    #[test]
    fn corrupt_texture_is_a_texture_error_naming_the_image() {
        let obj = textured_obj();
        let noise: Vec<u8> = (0..64u32).map(|k| (k.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
        let files: [(&str, &[u8]); 3] = [("m/quad.obj", obj.as_bytes()), ("m/quad.mtl", b"newmtl tex\nmap_Kd tex.png\n"), ("m/tex.png", &noise)];
        let e = load(&files, "m/quad.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Texture { path, .. } if path == "m/tex.png"), "{e}");
    }

    #[test]
    fn malformed_files_are_errors_naming_the_file() {
        for (obj, mtl) in [("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", ""), ("v 0 0 zero\n", ""), ("mtllib q.mtl\nv 0 0 0\n", "newmtl a\nKd 0.5 x 0.5\n")] {
            let e = load(&[("m/q.obj", obj.as_bytes()), ("m/q.mtl", mtl.as_bytes())], "m/q.obj").unwrap_err();
            let expected = if mtl.is_empty() { "m/q.obj" } else { "m/q.mtl" };
            assert!(matches!(&e, MeshError::Obj { .. }) && error_path(&e) == expected, "{obj}: {e}");
        }
    }

    #[test]
    fn out_of_range_indices_are_errors_not_panics() {
        for face in ["f 1 2 9", "f 1 2 0", "f 1 2 -9", "f 1/7 2/1 3/1"] {
            let obj = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n{face}\n");
            let e = load(&[("m/q.obj", obj.as_bytes())], "m/q.obj").unwrap_err();
            assert_eq!(error_path(&e), "m/q.obj", "{face}: {e}");
        }
    }

    #[test]
    fn degenerate_triangles_are_skipped_and_counted() {
        // A repeated index, a collinear triple and a good triangle.
        let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 2\nf 1 2 4\nf 1 2 3\n";
        let (mesh, report) = load(&[("m/q.obj", obj.as_bytes())], "m/q.obj").unwrap();
        assert_eq!((mesh.triangles.len(), report.degenerate_skipped), (1, 2));
        assert!(mesh.triangles[0].albedo.is_none());
        let e = load(&[("m/q.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")], "m/q.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Invalid { path, .. } if path == "m/q.obj"), "{e}");
    }

    #[test]
    fn unusable_meshes_are_invalid() {
        let nan = "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n";
        let e = load(&[("m/q.obj", nan.as_bytes())], "m/q.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Invalid { reason, .. } if reason.contains("vertex 2")), "{e}");
        let no_uv = format!("mtllib q.mtl\n{QUAD}usemtl tex\nf 1 2 3\n");
        let png = png();
        let files: [(&str, &[u8]); 3] = [("m/q.obj", no_uv.as_bytes()), ("m/q.mtl", b"newmtl tex\nmap_Kd t.png\n"), ("m/t.png", &png)];
        let e = load(&files, "m/q.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Invalid { reason, .. } if reason.contains("texture coordinates")), "{e}");
        let two = format!("mtllib q.mtl\n{QUAD}{UVS}usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\n");
        let mtl = b"newmtl a\nmap_Kd t.png\nnewmtl b\nmap_Kd u.png\n";
        let files: [(&str, &[u8]); 4] = [("m/q.obj", two.as_bytes()), ("m/q.mtl", mtl), ("m/t.png", &png), ("m/u.png", &png)];
        let e = load(&files, "m/q.obj").unwrap_err();
        assert!(matches!(&e, MeshError::Invalid { reason, .. } if reason.contains("more than one texture")), "{e}");
    }

    /// Whether tobj parses f64 (its `use_f64` feature) rather than f32.
    fn tobj_is_f64() -> bool {
        fn size_of_elem<T>(_: &[T]) -> usize {
            std::mem::size_of::<T>()
        }
        size_of_elem(&tobj::Mesh::default().positions) == 8
    }

    /// Write `mesh` with [`to_obj`] (and its texture as PNG), load it back with [`load_obj`] and
    /// compare triangle by triangle.
    fn assert_round_trip(mesh: &Mesh) {
        let png = mesh.texture.as_ref().map(|t| texture_png(t).unwrap());
        let (obj, mtl) = to_obj(mesh, "m.mtl", png.as_ref().map(|_| "m.png"));
        let mut files: HashMap<PathBuf, Vec<u8>> = [("d/m.obj", obj.into_bytes()), ("d/m.mtl", mtl.into_bytes())].map(|(p, b)| (p.into(), b)).into();
        files.extend(png.map(|b| (PathBuf::from("d/m.png"), b)));
        let read = |p: &Path| files.get(p).cloned().ok_or_else(|| std::io::Error::other("missing"));
        let (back, report) = load_obj(Path::new("d/m.obj"), &read).unwrap();
        assert_eq!((back.triangles.len(), report.degenerate_skipped), (mesh.triangles.len(), 0), "{}", mesh.name);
        // {:.9} is within 5e-10 m; tobj without `use_f64` then rounds to f32.
        let rel = if tobj_is_f64() { 0.0 } else { f64::from(f32::EPSILON) };
        for (i, (a, b)) in mesh.triangles.iter().zip(&back.triangles).enumerate() {
            for (p, q) in mesh.corners_m(i).iter().zip(back.corners_m(i)) {
                assert!((0..3).all(|k| (p[k] - q[k]).abs() <= 1e-9 + rel * p[k].abs()), "{}: triangle {i}: {p} vs {q}", mesh.name);
            }
            assert_eq!(a.albedo.is_some(), b.albedo.is_some());
            assert!(a.albedo.zip(b.albedo).is_none_or(|(x, y)| (x - y).abs() < 1e-4), "{}: triangle {i}", mesh.name);
            let (ua, ub) = (a.uv.map(|uv| uv.concat()), b.uv.map(|uv| uv.concat()));
            assert_eq!(ua.is_some(), ub.is_some());
            assert!(ua.zip(ub).is_none_or(|(x, y)| x.iter().zip(&y).all(|(s, t)| (s - t).abs() < 1e-6)), "{}: triangle {i}", mesh.name);
        }
        let texels = |m: &Mesh| m.texture.as_ref().map(|t| (t.width, t.height, t.texels.iter().map(|v| v.round()).collect::<Vec<_>>()));
        assert_eq!(texels(mesh), texels(&back), "{}", mesh.name);
    }

    #[test]
    fn to_obj_round_trips_through_load_obj() {
        for asset in assets() {
            assert_round_trip(&asset.mesh);
        }
        assert_round_trip(&icosphere(0.3, 3));
        let mut mixed = gripper();
        mixed.triangles[30..].iter_mut().for_each(|t| t.albedo = None);
        let (obj, _) = to_obj(&mixed, "g.mtl", None);
        assert!(obj.find("f ").unwrap() < obj.find("usemtl").unwrap(), "triangles without material come first");
    }
}
