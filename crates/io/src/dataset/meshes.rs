//! Meshes read from files for scene files, dataset specs and scenarios: each OBJ is loaded
//! ([`synthcam_core::mesh::obj::load_obj`]) and its hierarchy built once, then shared.
//!
//! A relative `mesh` path is taken as written when that file exists (relative to the working
//! directory, e.g. `assets/meshes/gripper.obj` from the repository root), else relative to the
//! folder of the file that names it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use synthcam_core::mesh::obj::load_obj;
use synthcam_core::mesh::{MeshError, Texture};
use synthcam_scene::file::AssetLoader;
use synthcam_scene::objects::MeshAsset;

/// A cache of loaded meshes.
#[derive(Debug, Default)]
pub struct MeshLibrary {
    base_dir: PathBuf,
    cache: Mutex<HashMap<PathBuf, Arc<MeshAsset>>>,
    images: Mutex<HashMap<PathBuf, Arc<Texture>>>,
}

impl MeshLibrary {
    /// A library resolving relative paths against `base_dir` when they do not exist as written.
    pub fn new(base_dir: &Path) -> Self {
        Self { base_dir: base_dir.to_path_buf(), cache: Mutex::new(HashMap::new()), images: Mutex::new(HashMap::new()) }
    }

    /// A library for the meshes named in the file `file` (its folder is the base).
    pub fn beside(file: &Path) -> Self {
        Self::new(file.parent().unwrap_or_else(|| Path::new(".")))
    }

    /// The file a `mesh` entry names.
    pub fn resolve(&self, path: &str) -> PathBuf {
        let p = Path::new(path);
        if p.is_absolute() || p.exists() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// The mesh at `path` (loaded and its hierarchy built on first use).
    ///
    /// # Errors
    /// As [`load_obj`] and [`MeshAsset::new`], naming the file.
    pub fn load(&self, path: &str) -> Result<Arc<MeshAsset>, MeshError> {
        cached(&self.cache, self.resolve(path), |file| {
            let (mesh, report) = load_obj(file, &|p: &Path| std::fs::read(p))?;
            if report.degenerate_skipped > 0 {
                log::warn!("{}: skipped {} degenerate triangles", file.display(), report.degenerate_skipped);
            }
            MeshAsset::new(mesh)
        })
    }

    /// The image at `path` as a grey texture (its luma; read on first use): a background.
    ///
    /// # Errors
    /// [`MeshError::Read`] or [`MeshError::Texture`], naming the file.
    pub fn image(&self, path: &str) -> Result<Arc<Texture>, MeshError> {
        cached(&self.images, self.resolve(path), |file| {
            let name = file.display().to_string();
            let bytes = std::fs::read(file).map_err(|source| MeshError::Read { path: name.clone(), source })?;
            let img = image::load_from_memory(&bytes).map_err(|source| MeshError::Texture { path: name, source })?;
            Ok(Arc::new(Texture::from_image(&img)))
        })
    }
}

/// The value `cache` holds for `file`, or `make(file)` stored under it.
fn cached<T>(cache: &Mutex<HashMap<PathBuf, Arc<T>>>, file: PathBuf, make: impl FnOnce(&Path) -> Result<Arc<T>, MeshError>) -> Result<Arc<T>, MeshError> {
    if let Some(v) = cache.lock().ok().and_then(|c| c.get(&file).cloned()) {
        return Ok(v);
    }
    let v = make(&file)?;
    if let Ok(mut c) = cache.lock() {
        c.insert(file, v.clone());
    }
    Ok(v)
}

impl AssetLoader for MeshLibrary {
    fn mesh(&self, path: &str) -> Result<Arc<MeshAsset>, MeshError> {
        self.load(path)
    }

    fn texture(&self, path: &str) -> Result<Arc<Texture>, MeshError> {
        self.image(path)
    }
}
