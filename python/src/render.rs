//! `render`, `render_depth_mask`, `adapter`, `load_image`: one shared GPU renderer per process,
//! opened on first use (Vulkan, then GL), used with the GIL released.

use std::path::PathBuf;
use std::sync::OnceLock;

use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use synthcam::dataset::{truth_json, MeshLibrary};
use synthcam::render::{GreyImage, Renderer};
use synthcam::scene::file::parse_scene_with;
use synthcam::scene::Scene;

use crate::convert::{chain, err, image_to_py, json_to_py, text_or_json};

static RENDERER: OnceLock<Renderer> = OnceLock::new();

/// The process's renderer, opened on first use. Two threads racing to open it both succeed; one
/// renderer is kept.
pub fn renderer() -> Result<&'static Renderer, String> {
    if let Some(r) = RENDERER.get() {
        return Ok(r);
    }
    let opened = Renderer::headless().map_err(|e| format!("opening the GPU: {}", chain(&e)))?;
    Ok(RENDERER.get_or_init(|| opened))
}

/// Parse scene text, loading `[[object]]` meshes and `[background]` images relative to
/// `base_dir` (default: the working directory).
fn parse(text: &str, base_dir: Option<PathBuf>) -> Result<Scene, String> {
    let meshes = MeshLibrary::new(&base_dir.unwrap_or_else(|| PathBuf::from(".")));
    parse_scene_with(text, &meshes).map_err(|e| format!("in the scene: {}", chain(&e)))
}

/// Render a scene: returns `(image, truth)`. The image is a NumPy array ((H, W) uint8, uint16
/// for 16-bit output, (H, W, 3) for RGB); `truth` the truth labels as a dict (the JSON the CLI
/// writes beside an image: camera, `cam_from_target`, every feature's exact pixel).
///
/// `scene` is a scene file's text (TOML, or JSON) or the same as a dict. Meshes named by
/// `[[object]]` and images named by `[background]` are read relative to `base_dir` (default:
/// the working directory). The GIL is
/// released while the scene is parsed, rendered and labelled.
#[pyfunction]
#[pyo3(signature = (scene, base_dir=None))]
pub fn render<'py>(py: Python<'py>, scene: &Bound<'py, PyAny>, base_dir: Option<PathBuf>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let text = text_or_json(scene, "scene")?;
    let (img, truth): (GreyImage, Vec<u8>) = py
        .detach(move || -> Result<_, String> {
            let scene = parse(&text, base_dir)?;
            let img = renderer()?.render(&scene).map_err(|e| format!("rendering: {}", chain(&e)))?;
            let truth = truth_json(&synthcam::scene::truth::truth_labels(&scene)).map_err(|e| chain(&e))?;
            Ok((img, truth))
        })
        .map_err(err)?;
    let truth = String::from_utf8(truth).map_err(|e| err(format!("truth JSON: {e}")))?;
    Ok((image_to_py(py, img)?, json_to_py(py, &truth)?))
}

/// The scene's depth image and instance mask: `(depth, mask)`, (H, W) float32 metres along the
/// camera's z (NaN where nothing is seen) and (H, W) uint16 ids (0 nothing, 1 the target, 2 + i
/// object i). Exact f64 ray casts on the CPU, one ray per pixel centre.
#[pyfunction]
#[pyo3(signature = (scene, base_dir=None))]
pub fn render_depth_mask<'py>(py: Python<'py>, scene: &Bound<'py, PyAny>, base_dir: Option<PathBuf>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let text = text_or_json(scene, "scene")?;
    let m = py.detach(move || parse(&text, base_dir).map(|s| synthcam::scene::depth::depth_mask(&s))).map_err(err)?;
    let shape = (m.height as usize, m.width as usize);
    let depth = Array2::from_shape_vec(shape, m.depth_m).map_err(|e| err(format!("depth: {e}")))?;
    let mask = Array2::from_shape_vec(shape, m.instance).map_err(|e| err(format!("mask: {e}")))?;
    Ok((depth.into_pyarray(py).into_any(), mask.into_pyarray(py).into_any()))
}

/// The GPU adapter the renderer runs on (e.g. "llvmpipe (LLVM 15.0.6, 256 bits) / Vulkan"),
/// opening it if needed.
#[pyfunction]
pub fn adapter(py: Python<'_>) -> PyResult<String> {
    py.detach(|| renderer().map(|r| r.context().describe())).map_err(err)
}

/// Read an image file (PNG or JPEG) as a NumPy array: (H, W) uint8 or uint16 for grey images,
/// (H, W, 3) for colour ones, as stored.
#[pyfunction]
pub fn load_image(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyAny>> {
    let img = py
        .detach(|| -> Result<GreyImage, String> {
            let decoded = image::open(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
            Ok(GreyImage::from(decoded))
        })
        .map_err(err)?;
    image_to_py(py, img)
}
