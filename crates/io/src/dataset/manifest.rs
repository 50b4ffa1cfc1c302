//! Dataset manifests: one JSON line per image (`manifest.jsonl`, or `manifest-shardI-ofN.jsonl`
//! for shard I of N), sorted by k, and their merge and verification.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::DatasetError;

/// The complete manifest of a dataset folder.
pub const MANIFEST: &str = "manifest.jsonl";

/// `cam_from_target` as written to the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestPose {
    /// Rodrigues vector, radians.
    pub rvec: [f64; 3],
    /// Translation, metres.
    pub t_m: [f64; 3],
}

/// One image of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifestEntry {
    /// Image index.
    pub k: u64,
    /// PNG path relative to the dataset folder.
    pub file: String,
    /// SHA-256 of the PNG bytes, lowercase hex.
    pub sha256: String,
    /// Truth JSON path relative to the dataset folder.
    pub truth: String,
    /// Noise seed of the render.
    pub seed: u64,
    /// `cam_from_target`.
    pub cam_from_target: ManifestPose,
    /// Robot joints, radians (robot mode).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub joints_rad: Option<[f64; 6]>,
    /// A rig: every camera's image of frame k, the first camera's included (the fields above are
    /// the first camera's).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub cameras: Option<Vec<ManifestCamera>>,
}

/// One camera's image of a rig frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ManifestCamera {
    /// The camera's name.
    pub name: String,
    /// Image path relative to the dataset folder (`images/<name>/NNNNNN.png`).
    pub file: String,
    /// SHA-256 of the image bytes.
    pub sha256: String,
    /// Truth JSON path.
    pub truth: String,
    /// Noise seed of the render.
    pub seed: u64,
    /// This camera's `cam_from_target`.
    pub cam_from_target: ManifestPose,
}

/// Lowercase hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// File name of shard `index` of `count`'s manifest ([`MANIFEST`] when unsharded).
pub fn shard_manifest_name(index: u64, count: u64) -> String {
    if count == 1 {
        MANIFEST.to_string()
    } else {
        format!("manifest-shard{index}-of{count}.jsonl")
    }
}

/// Serialise entries sorted by k, one JSON line each.
///
/// # Errors
/// [`DatasetError::Json`].
pub fn manifest_text(entries: &[ManifestEntry]) -> Result<String, DatasetError> {
    let mut sorted: Vec<&ManifestEntry> = entries.iter().collect();
    sorted.sort_by_key(|e| e.k);
    let mut s = String::new();
    for e in sorted {
        s += &serde_json::to_string(e).map_err(|e| DatasetError::Json(e.to_string()))?;
        s.push('\n');
    }
    Ok(s)
}

/// Parse manifest text: each entry with its line as written (the merge copies lines verbatim, so
/// numbers are never re-formatted).
///
/// # Errors
/// [`DatasetError::Read`] naming the line.
pub fn parse_manifest<'t>(path: &Path, text: &'t str) -> Result<Vec<(ManifestEntry, &'t str)>, DatasetError> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            serde_json::from_str(l).map(|e| (e, l)).map_err(|e| DatasetError::Read { path: path.display().to_string(), reason: format!("line {}: {e}", i + 1) })
        })
        .collect()
}

/// Why an image fails verification.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BadImage {
    /// Image index.
    pub k: u64,
    /// What is wrong.
    pub reason: String,
}

/// Result of [`merge_manifests`].
#[derive(Debug, Clone, PartialEq)]
pub struct MergeReport {
    /// Manifest files read.
    pub sources: Vec<String>,
    /// Images listed and verified.
    pub images: u64,
}

/// Join the shard manifests of `dir` (or its [`MANIFEST`] when there are none), verify that every
/// k in 0..count is listed exactly once, that its PNG and truth JSON exist and that the PNG's
/// SHA-256 matches; then write `dir/manifest.jsonl` sorted by k.
///
/// # Errors
/// [`DatasetError::Incomplete`] listing missing and bad k (nothing is written then), or a
/// read/write error.
pub fn merge_manifests(dir: &Path, count: u64) -> Result<MergeReport, DatasetError> {
    let read_err = |p: &Path, e: std::io::Error| DatasetError::Read { path: p.display().to_string(), reason: e.to_string() };
    let mut sources: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| read_err(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("manifest-shard") && n.ends_with(".jsonl")))
        .collect();
    sources.sort();
    if sources.is_empty() && dir.join(MANIFEST).exists() {
        sources.push(dir.join(MANIFEST));
    }
    let mut by_k: BTreeMap<u64, (ManifestEntry, String)> = BTreeMap::new();
    let mut bad: Vec<BadImage> = Vec::new();
    for src in &sources {
        let text = std::fs::read_to_string(src).map_err(|e| read_err(src, e))?;
        for (e, line) in parse_manifest(src, &text)? {
            if e.k >= count {
                bad.push(BadImage { k: e.k, reason: format!("k out of range 0..{count}") });
            } else {
                match by_k.entry(e.k) {
                    std::collections::btree_map::Entry::Occupied(_) => {
                        bad.push(BadImage { k: e.k, reason: format!("listed more than once (again in {})", src.display()) });
                    }
                    std::collections::btree_map::Entry::Vacant(v) => {
                        v.insert((e, line.to_string()));
                    }
                }
            }
        }
    }
    let missing: Vec<u64> = (0..count).filter(|k| !by_k.contains_key(k)).collect();
    let checks: Vec<Option<BadImage>> = {
        use rayon::prelude::*;
        by_k.values().collect::<Vec<_>>().par_iter().map(|(e, _)| verify_entry(dir, e)).collect()
    };
    bad.extend(checks.into_iter().flatten());
    bad.sort_by_key(|b| b.k);
    if !missing.is_empty() || !bad.is_empty() {
        return Err(DatasetError::Incomplete { missing, bad });
    }
    let text: String = by_k.into_values().map(|(_, line)| line + "\n").collect();
    super::write_atomic(&dir.join(MANIFEST), text.as_bytes())?;
    Ok(MergeReport { sources: sources.iter().map(|p| p.display().to_string()).collect(), images: count })
}

fn verify_entry(dir: &Path, e: &ManifestEntry) -> Option<BadImage> {
    let files = std::iter::once((&e.file, &e.sha256, &e.truth)).chain(e.cameras.iter().flatten().map(|c| (&c.file, &c.sha256, &c.truth)));
    files.into_iter().find_map(|(file, sha256, truth)| verify_files(dir, file, sha256, truth)).map(|reason| BadImage { k: e.k, reason })
}

/// What is wrong with one image and its truth, if anything.
fn verify_files(dir: &Path, file: &str, sha256: &str, truth: &str) -> Option<String> {
    match std::fs::read(dir.join(file)) {
        Ok(bytes) => {
            let sha = sha256_hex(&bytes);
            if sha != sha256 {
                return Some(format!("{file}: sha256 {sha} does not match the manifest's {sha256}"));
            }
        }
        Err(err) => return Some(format!("{file}: {err}")),
    }
    (!dir.join(truth).is_file()).then(|| format!("{truth}: missing"))
}

/// The message of [`DatasetError::Incomplete`]: the missing k compacted, the first 50 bad k with
/// their reasons.
pub fn incomplete_message(missing: &[u64], bad: &[BadImage]) -> String {
    let mut s = format!("dataset incomplete: {} missing", missing.len());
    if !missing.is_empty() {
        s += &format!(" (k = {})", format_ks(missing));
    }
    s += &format!(", {} bad", bad.len());
    for b in bad.iter().take(50) {
        s += &format!("\n  k = {}: {}", b.k, b.reason);
    }
    s
}

/// Compact list of k values: `0-3, 7, 9-10`.
pub fn format_ks(ks: &[u64]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < ks.len() {
        let mut j = i;
        while j + 1 < ks.len() && ks[j + 1] == ks[j] + 1 {
            j += 1;
        }
        parts.push(if i == j { ks[i].to_string() } else { format!("{}-{}", ks[i], ks[j]) });
        i = j + 1;
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_abc() {
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    }

    #[test]
    fn ks_are_compacted() {
        assert_eq!(format_ks(&[0, 1, 2, 3, 7, 9, 10]), "0-3, 7, 9-10");
        assert_eq!(format_ks(&[]), "");
    }
}
