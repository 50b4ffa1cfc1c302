//! `#[repr(C)]` uniform structs mirroring the WGSL structs of `shaders/bindings.wgsl`.

use bytemuck::{Pod, Zeroable};

/// Mirrors WGSL `Params` in `shaders/bindings.wgsl` (all fields are 16-byte vectors).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, Default, PartialEq)]
pub struct Params {
    /// width, height, pass kind (`gpu_scene::pass_kind`), samples per axis.
    pub size: [u32; 4],
    /// tiles_x, tiles_y, dot style (0 bead, 1 disc), fine-pass work length.
    pub tiles: [u32; 4],
    /// fx, fy, cx, cy.
    pub intr: [f32; 4],
    /// skew, r2_max, has_distortion, 0 (the lens model is a pipeline constant).
    pub intr2: [f32; 4],
    /// OpenCV: k1, k2, p1, p2; fisheye: k1, k2, k3, k4; Double Sphere: xi, alpha, 0, 0.
    pub dist0: [f32; 4],
    /// OpenCV: k3, k4, k5, k6; fisheye: theta_max, the distorted radii beyond which a pixel is
    /// split into 2 x 2 and 4 x 4 sub-pixels (`render::bend`), 0.
    pub dist1: [f32; 4],
    /// OpenCV: s1, s2, s3, s4.
    pub dist2: [f32; 4],
    /// OpenCV tilt matrix row 0 (xyz; whether it is used is a pipeline constant).
    pub tilt0: [f32; 4],
    /// Tilt matrix row 1.
    pub tilt1: [f32; 4],
    /// Tilt matrix row 2.
    pub tilt2: [f32; 4],
    /// Homography row 0 (target plane from normalised coordinates).
    pub h0: [f32; 4],
    /// Homography row 1.
    pub h1: [f32; 4],
    /// Homography row 2.
    pub h2: [f32; 4],
    /// Chessboard: nx, ny, square, margin; dot grid: n, edge, radius, margin; coded boards: cells
    /// along x and y, sub-intervals per period, margin.
    pub board: [f32; 4],
    /// dark, light, margin, background grey levels.
    pub grey: [f32; 4],
    /// S-path sphere centre (camera frame) and radius.
    pub sphere: [f32; 4],
    /// Coded boards' cell lattice (`target::CellLattice`): period, origin, first sub-interval,
    /// cell, metres.
    pub lat: [f32; 4],
    /// Coded boards: the board's end along x and y, the narrowest cell (metres), 0.
    pub lat2: [f32; 4],
    /// Planar targets: views per pixel, one set of views per row (1) or one for all rows (0), 0,
    /// 0 (the shader finds the views' spread per pixel: `shaders/entries.wgsl` `views_spread`).
    pub vw: [u32; 4],
    /// Objects (`shaders/objects.wgsl`): instances, the first instance row in the objects
    /// buffer, fine-pass samples per axis, 0.
    pub obj: [u32; 4],
    /// Planar targets: the target plane `n . x = c` in the camera frame, `(n, c)`.
    pub plane: [f32; 4],
    /// Planar targets: the printed sheet in the target plane, `x0, y0, x1, y1`, metres.
    pub sheet: [f32; 4],
    /// Warped boards (`shaders/planar.wgsl` `warp_view`): `kx, ky` (metres), `lambda` (the
    /// uniform homography is `[r1 r2 t]^-1 / lambda`), 1 when warped (else all 0).
    pub warp: [f32; 4],
    /// Warped boards: the feature extent's centre `xc, yc` and scales `sx, sy` (`u = (x - xc) sx`).
    pub warp_c: [f32; 4],
    /// Warped boards: row 0 of `target_from_cam`'s rotation (xyz) and the camera centre's x in the
    /// target frame (w).
    pub tfc0: [f32; 4],
    /// Row 1 (w: the camera centre's y).
    pub tfc1: [f32; 4],
    /// Row 2 (w: the camera centre's z).
    pub tfc2: [f32; 4],
    /// Planar targets under a point or area light (`synthcam_scene::lighting`): the constant part
    /// of the shading (ambient and directional lights), 1 when the point light is on, 2 the area
    /// light (else all 0: the grey levels are used as they are), the gloss's `F0` and roughness
    /// (0: no gloss).
    pub shade: [f32; 4],
    /// The point light in the target frame: `x, y, z`, intensity; an area light: the first corner
    /// of its polygon above the board's horizon and its radiance.
    pub lamp: [f32; 4],
    /// The polygon's second corner, target frame (the last corner repeated up to the fifth).
    pub area1: [f32; 4],
    /// Its third corner.
    pub area2: [f32; 4],
    /// Its fourth corner.
    pub area3: [f32; 4],
    /// Its fifth corner.
    pub area4: [f32; 4],
    /// The emitter's plane in the target frame: its normal towards where it emits and offset.
    pub area_e: [f32; 4],
    /// The camera centre in the target frame `x, y, z`, and the camera-side normal's z (+-1).
    pub eye: [f32; 4],
    /// Background (`shaders/background.wgsl`): kind (0 none, 1 panorama, 2 plane), the image's
    /// width and height (texels), 0.
    pub bg: [f32; 4],
    /// Row 0 of the background's frame from the camera's (xyz) and, for a plane, the camera
    /// centre's x in the plane's frame (w).
    pub bg0: [f32; 4],
    /// Row 1 (w: the camera centre's y).
    pub bg1: [f32; 4],
    /// Row 2 (w: the camera centre's z).
    pub bg2: [f32; 4],
    /// A plane image's width and height, metres, 0, 0.
    pub bg_size: [f32; 4],
    /// The objects' shadows (`shaders/objects.wgsl` `shadowed`): the direction towards the light
    /// in the camera frame (0: no shadows), the shadowed over the lit shading of the target.
    pub sun: [f32; 4],
    /// The objects' soft shadows (`shaders/objects.wgsl` `light_share`): the area light's corner
    /// in the camera frame and the ambient term.
    pub soft_c: [f32; 4],
    /// Its edge along the width, camera frame; w: 1 when soft shadows are on.
    pub soft_u: [f32; 4],
    /// Its edge along the height, camera frame; w: the soft-shadow lattice's first row in the
    /// objects' buffer (0: none; -1 while the lattice's own points are computed:
    /// `super::soft_lattice`).
    pub soft_v: [f32; 4],
    /// Lit objects (`shaders/objects.wgsl` `sun_on`): the directional light's irradiance `E`
    /// times the unit direction towards it (camera frame; 0: no light), the ambient term `A`.
    pub obj_sun: [f32; 4],
}

impl Params {
    /// Whether the objects cast soft shadows from an area light (`soft_u`'s flag).
    pub(crate) fn soft_shadows(&self) -> bool {
        self.soft_u[3] == 1.0
    }
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use super::Params;
    use crate::shader::SHADER;

    /// `Params`'s fields as the Rust struct lays them out: (name, byte offset).
    fn rust_layout() -> Vec<(String, usize)> {
        macro_rules! fields {
            ($($f:ident),*) => { vec![$((stringify!($f).to_string(), offset_of!(Params, $f))),*] };
        }
        fields!(
            size, tiles, intr, intr2, dist0, dist1, dist2, tilt0, tilt1, tilt2, h0, h1, h2, board, grey, sphere, lat, lat2, vw, obj, plane, sheet, warp,
            warp_c, tfc0, tfc1, tfc2, shade, lamp, area1, area2, area3, area4, area_e, eye, bg, bg0, bg1, bg2, bg_size, sun, soft_c, soft_u, soft_v, obj_sun
        )
    }

    /// WGSL struct `name`'s members (name, byte offset) and size, from naga's reflection of the
    /// assembled shader.
    fn wgsl_layout(source: &str, name: &str) -> (Vec<(String, usize)>, usize) {
        let module = wgpu::naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(source)));
        let ty = module.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).map(|(_, t)| &t.inner);
        let Some(wgpu::naga::TypeInner::Struct { members, span }) = ty else { panic!("no struct {name} in the shader") };
        (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize)).collect(), *span as usize)
    }

    /// The value of the shader's `const name: u32`.
    fn wgsl_u32_const(source: &str, name: &str) -> Option<u32> {
        let module = wgpu::naga::front::wgsl::parse_str(source).ok()?;
        let (_, c) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name))?;
        match module.global_expressions[c.init] {
            wgpu::naga::Expression::Literal(wgpu::naga::Literal::U32(v)) => Some(v),
            _ => None,
        }
    }

    #[test]
    fn shader_kinds_are_the_rust_ones() {
        use crate::gpu_scene::PassKind;
        let names = [
            "KIND_CHESSBOARD",
            "KIND_DOT_GRID",
            "KIND_SPATH",
            "KIND_SPATH_LIMB",
            "KIND_CODED",
            "KIND_CHESSBOARD_VIEWS",
            "KIND_DOT_GRID_VIEWS",
            "KIND_CODED_VIEWS",
            "KIND_OBJECTS",
            "KIND_BACKGROUND",
        ];
        for (kind, name) in PassKind::ALL.into_iter().zip(names) {
            assert_eq!(wgsl_u32_const(SHADER, name), Some(kind as u32), "{name} vs PassKind::{kind:?}");
        }
        // the check reads the shader: a changed value fails it
        let changed = SHADER.replacen("const KIND_CODED: u32 = 4u;", "const KIND_CODED: u32 = 5u;", 1);
        assert_ne!(wgsl_u32_const(&changed, "KIND_CODED"), Some(PassKind::Coded as u32));
    }

    #[test]
    fn every_pass_has_its_entry_points_in_the_shader() {
        let module = wgpu::naga::front::wgsl::parse_str(SHADER).expect("the shader parses");
        let names: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        for kind in crate::gpu_scene::PassKind::ALL {
            for entry in kind.entry_points() {
                assert!(names.contains(&entry), "{kind:?}: no entry point {entry} in {names:?}");
            }
        }
        assert_eq!(
            names.len(),
            10,
            "a coarse / fine pair per pass (planar, planar with views, S-path, objects), the S-path's dotless tiles' coarse entry and the background's: {names:?}"
        );
    }

    #[test]
    fn params_matches_the_shader_by_name_and_offset() {
        let (wgsl, span) = wgsl_layout(SHADER, "Params");
        assert_eq!(rust_layout(), wgsl, "Params (crates/render/src/uniforms.rs) and the shader's `struct Params` (shaders/bindings.wgsl) differ");
        assert_eq!(size_of::<Params>(), span);
    }

    #[test]
    fn the_layout_check_sees_two_fields_swapped() {
        // the shader with `intr` and `intr2` declared the other way round
        let (intr, intr2) = ("    intr: vec4<f32>,", "    intr2: vec4<f32>,");
        assert!(SHADER.contains(intr) && SHADER.contains(intr2));
        let swapped = SHADER.replacen(intr, "SWAP", 1).replacen(intr2, intr, 1).replacen("SWAP", intr2, 1);
        assert_ne!(rust_layout(), wgsl_layout(&swapped, "Params").0);
    }
}
