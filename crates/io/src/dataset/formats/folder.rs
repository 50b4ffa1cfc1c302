//! Reading a finished dataset folder: `spec.toml`, `manifest.jsonl` (complete: every image of
//! the spec listed once), `images/NNNNNN.png|jpg` and `images/NNNNNN.json`.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::FormatError;
use crate::dataset::generate::SPEC_COPY;
use crate::dataset::manifest::{parse_manifest, sha256_hex, ManifestEntry, MANIFEST};
use crate::dataset::spec::{DatasetPlan, DatasetSpec};
use crate::dataset::DatasetError;
use synthcam_scene::truth::TruthLabels;

/// A dataset folder whose manifest lists every image of its spec.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetFolder {
    /// The folder.
    pub dir: PathBuf,
    /// Its `spec.toml`.
    pub spec_text: String,
    /// The manifest, sorted by k.
    pub entries: Vec<ManifestEntry>,
}

fn read_err(path: &Path, reason: impl ToString) -> DatasetError {
    DatasetError::Read { path: path.display().to_string(), reason: reason.to_string() }
}

impl DatasetFolder {
    /// Open `dir`: its spec copy and complete manifest.
    ///
    /// # Errors
    /// [`DatasetError::Read`] for a missing or unparsable spec or manifest (a sharded run not yet
    /// merged has no `manifest.jsonl`), [`DatasetError::Incomplete`] when images are missing.
    pub fn open(dir: &Path) -> Result<Self, FormatError> {
        let spec_path = dir.join(SPEC_COPY);
        let spec_text = std::fs::read_to_string(&spec_path).map_err(|e| read_err(&spec_path, format!("{e} (is {} a dataset folder?)", dir.display())))?;
        let spec: DatasetSpec = toml::from_str(&spec_text).map_err(|e| read_err(&spec_path, e))?;
        let manifest_path = dir.join(MANIFEST);
        let text = std::fs::read_to_string(&manifest_path)
            .map_err(|e| read_err(&manifest_path, format!("{e} (a sharded dataset needs `synthcam dataset merge {}` first)", dir.display())))?;
        let mut entries: Vec<ManifestEntry> = parse_manifest(&manifest_path, &text)?.into_iter().map(|(e, _)| e).collect();
        entries.sort_by_key(|e| e.k);
        entries.dedup_by_key(|e| e.k);
        let missing: Vec<u64> = (0..spec.count).filter(|k| entries.binary_search_by_key(k, |e| e.k).is_err()).collect();
        if !missing.is_empty() || entries.len() as u64 != spec.count {
            return Err(DatasetError::Incomplete { missing, bad: Vec::new() }.into());
        }
        Ok(DatasetFolder { dir: dir.to_path_buf(), spec_text, entries })
    }

    /// The validated spec (mesh paths resolved beside the spec copy).
    ///
    /// # Errors
    /// [`DatasetError::Spec`].
    pub fn plan(&self) -> Result<DatasetPlan, FormatError> {
        let meshes = crate::dataset::MeshLibrary::beside(&self.dir.join(SPEC_COPY));
        Ok(crate::dataset::spec::parse_dataset_spec_with(&self.spec_text, &meshes).map_err(DatasetError::from)?)
    }

    /// Image paths relative to the folder, by k.
    pub fn image_names(&self) -> Vec<String> {
        self.entries.iter().map(|e| e.file.clone()).collect()
    }

    /// Entry `e`'s truth labels.
    ///
    /// # Errors
    /// [`DatasetError::Read`] or [`FormatError::Corrupt`] for a file that does not parse.
    pub fn read_truth(&self, e: &ManifestEntry) -> Result<TruthLabels, FormatError> {
        let path = self.dir.join(&e.truth);
        let bytes = std::fs::read(&path).map_err(|err| read_err(&path, err))?;
        serde_json::from_slice(&bytes).map_err(|err| FormatError::Corrupt { path: path.display().to_string(), reason: format!("truth JSON: {err}") })
    }

    /// Entry `e`'s truth JSON as written.
    ///
    /// # Errors
    /// [`DatasetError::Read`].
    pub fn read_truth_bytes(&self, e: &ManifestEntry) -> Result<Vec<u8>, FormatError> {
        let path = self.dir.join(&e.truth);
        Ok(std::fs::read(&path).map_err(|err| read_err(&path, err))?)
    }

    /// Every truth, by k (read in parallel), calling `tick` after each.
    ///
    /// # Errors
    /// The first failure of [`Self::read_truth`].
    pub fn truths(&self, tick: super::Tick<'_>) -> Result<Vec<TruthLabels>, FormatError> {
        self.entries
            .par_iter()
            .map(|e| {
                let t = self.read_truth(e);
                tick();
                t
            })
            .collect()
    }

    /// Entry `e`'s encoded image, checked against the manifest's SHA-256.
    ///
    /// # Errors
    /// [`DatasetError::Read`], or [`FormatError::Corrupt`] when the hash differs.
    pub fn read_image(&self, e: &ManifestEntry) -> Result<Vec<u8>, FormatError> {
        let path = self.dir.join(&e.file);
        let bytes = std::fs::read(&path).map_err(|err| read_err(&path, err))?;
        let sha = sha256_hex(&bytes);
        if sha != e.sha256 {
            return Err(FormatError::Corrupt { path: path.display().to_string(), reason: format!("sha256 {sha} does not match the manifest's {}", e.sha256) });
        }
        Ok(bytes)
    }

    /// Entry `e`'s extra outputs that exist: (`depth.npy` | `mask.png`, bytes).
    ///
    /// # Errors
    /// [`DatasetError::Read`] for a file that exists and cannot be read.
    pub fn read_extras(&self, e: &ManifestEntry) -> Result<Vec<(&'static str, Vec<u8>)>, FormatError> {
        let mut out = Vec::new();
        for ext in ["depth.npy", "mask.png"] {
            let path = self.dir.join(&e.file).with_extension(ext);
            if path.is_file() {
                out.push((ext, std::fs::read(&path).map_err(|err| read_err(&path, err))?));
            }
        }
        Ok(out)
    }
}
