//! Dataset formats for other tools: COCO keypoints JSON ([`coco`]), WebDataset tar shards
//! ([`webdataset`]) and ROS 2 bags in MCAP ([`mcap`]), as one file or a rosbag2 folder ([`bag`]).
//!
//! Each writer is a pure function from in-memory data (truth labels, image bytes) to bytes or a
//! [`std::io::Write`]; [`export`] reads a finished dataset folder ([`folder`]) and writes a format
//! atomically (a temporary name, then a rename), so a failed export leaves no half-written file.

pub mod bag;
pub mod coco;
pub mod folder;
pub mod mcap;
pub mod ros2_msgs;
#[cfg(feature = "rerun")]
pub mod rrd;
pub mod series;
pub mod webdataset;

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::DatasetError;

/// A dataset format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// COCO keypoints JSON (`coco.json`).
    Coco,
    /// WebDataset tar shards (`webdataset/shard-000000.tar`, ...).
    WebDataset,
    /// A ROS 2 bag in MCAP (`ros2.mcap`): robot-mode datasets only.
    Mcap,
    /// The same bag as a rosbag2 folder (`rosbag2/`: `metadata.yaml`, `rosbag2_0.mcap`), which
    /// `ros2 bag play DIR` opens.
    Rosbag2,
}

impl Format {
    /// Every format, in the order of the docs.
    pub const ALL: [Format; 4] = [Format::Coco, Format::WebDataset, Format::Mcap, Format::Rosbag2];

    /// The name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Format::Coco => "coco",
            Format::WebDataset => "webdataset",
            Format::Mcap => "mcap",
            Format::Rosbag2 => "rosbag2",
        }
    }

    /// Where the format goes inside a dataset folder when no output is given.
    pub fn default_output(self, dir: &Path) -> PathBuf {
        match self {
            Format::Coco => dir.join("coco.json"),
            Format::WebDataset => dir.join("webdataset"),
            Format::Mcap => dir.join("ros2.mcap"),
            Format::Rosbag2 => dir.join("rosbag2"),
        }
    }
}

impl std::str::FromStr for Format {
    type Err = FormatError;
    fn from_str(s: &str) -> Result<Self, FormatError> {
        Format::ALL.into_iter().find(|f| f.name() == s).ok_or_else(|| FormatError::UnknownFormat(s.to_string()))
    }
}

/// Errors of the format writers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FormatError {
    /// A format name that is not one of [`Format::ALL`].
    #[error("unknown format `{0}` (coco, webdataset, mcap, rosbag2)")]
    UnknownFormat(String),
    /// The dataset folder could not be read, or a file could not be written.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A file of the dataset is not what its manifest says.
    #[error("{path}: {reason}")]
    Corrupt {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// The format needs something this dataset does not have.
    #[error("{format} cannot hold this dataset: {reason}")]
    Unsupported {
        /// The format.
        format: &'static str,
        /// Why.
        reason: String,
    },
    /// An output file could not be written.
    #[error("cannot write {path}")]
    Write {
        /// The path.
        path: String,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The rerun recording could not be written (the `rerun` feature).
    #[error("cannot write the rerun recording {path}: {reason}")]
    Rerun {
        /// The path.
        path: String,
        /// The recorder's error.
        reason: String,
    },
    /// The MCAP writer failed.
    #[error("cannot write the MCAP file {path}")]
    Mcap {
        /// The path.
        path: String,
        /// The writer's error.
        #[source]
        source: ::mcap::McapError,
    },
}

/// Options of [`export`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExportOptions {
    /// WebDataset: start a new shard before a sample that would take a shard past this many bytes.
    pub shard_bytes: u64,
    /// MCAP: time between consecutive images of a dataset, nanoseconds.
    pub frame_period_ns: u64,
}

/// WebDataset's usual shard size, 1 GB.
pub const DEFAULT_SHARD_BYTES: u64 = 1_000_000_000;

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions { shard_bytes: DEFAULT_SHARD_BYTES, frame_period_ns: series::DEFAULT_FRAME_PERIOD_NS }
    }
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportReport {
    /// The format.
    pub format: Format,
    /// The file or folder written.
    pub output: PathBuf,
    /// Images exported.
    pub images: u64,
    /// Files written (shards for WebDataset, else 1).
    pub files: u64,
    /// Bytes written.
    pub bytes: u64,
}

/// Called once per image exported (from any thread), for progress bars.
pub type Tick<'a> = &'a (dyn Fn() + Sync);

/// Export the dataset folder `dir` as `format` to `out` (default [`Format::default_output`]);
/// `tick` is called once per image.
///
/// # Errors
/// A missing or incomplete dataset folder, a corrupt file, a format that cannot hold the
/// dataset, or a write failure; nothing is left at `out` then (an earlier export there is kept).
pub fn export(dir: &Path, format: Format, out: Option<&Path>, opts: &ExportOptions, tick: Tick<'_>) -> Result<ExportReport, FormatError> {
    export_folder(&folder::DatasetFolder::open(dir)?, format, out, opts, tick)
}

/// [`export`] of a folder already opened (several formats read its manifest once).
///
/// # Errors
/// As [`export`].
pub fn export_folder(
    folder: &folder::DatasetFolder,
    format: Format,
    out: Option<&Path>,
    opts: &ExportOptions,
    tick: Tick<'_>,
) -> Result<ExportReport, FormatError> {
    if folder.entries.iter().any(|e| e.cameras.is_some()) {
        // Each format holds one image stream; exporting the first camera alone would drop data.
        return Err(FormatError::Unsupported {
            format: format.name(),
            reason: "a rig dataset ([[cameras]]) has one image per camera per frame; the exports hold one camera's stream (read images/<camera>/ directly)"
                .into(),
        });
    }
    let output = out.map_or_else(|| format.default_output(&folder.dir), Path::to_path_buf);
    let (files, bytes) = match format {
        Format::Coco => {
            let json = coco::coco_json(&folder.truths(tick)?, &folder.image_names())?;
            write_atomic_with(&output, |w| w.write_all(&json).map_err(|e| write_err(&output, e)))?;
            (1, json.len() as u64)
        }
        Format::WebDataset => webdataset::write_folder(folder, &output, opts.shard_bytes, tick)?,
        Format::Mcap | Format::Rosbag2 => {
            let bag = if format == Format::Mcap { bag::BagOutput::File(output.clone()) } else { bag::BagOutput::Rosbag2(output.clone()) };
            (1, series::write_dataset_bag(folder, &bag, opts.frame_period_ns, tick)?)
        }
    };
    Ok(ExportReport { format, output, images: folder.entries.len() as u64, files, bytes })
}

pub(crate) fn write_err(path: &Path, source: std::io::Error) -> FormatError {
    FormatError::Write { path: path.display().to_string(), source }
}

/// The temporary name beside `path` that [`write_atomic_with`] writes first.
pub(crate) fn tmp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp{}", std::process::id()))
}

/// Write the folder `out` through `fill` on a temporary folder beside it, then put it in place of
/// `out` (an earlier output there, which `is_ours` recognises, is replaced). The temporary folder is
/// removed on any failure.
///
/// # Errors
/// `fill`'s error, [`FormatError::Write`], or `out` exists and `is_ours` does not accept it (`what`
/// names what it should be).
pub fn write_folder_atomic<T, F>(out: &Path, what: &str, is_ours: impl Fn(&Path) -> bool, fill: F) -> Result<T, FormatError>
where
    F: FnOnce(&Path) -> Result<T, FormatError>,
{
    if out.exists() && (!out.is_dir() || !is_ours(out)) {
        return Err(write_err(out, std::io::Error::new(std::io::ErrorKind::AlreadyExists, format!("exists and is not {what}"))));
    }
    let tmp = tmp_path(out);
    let _ = std::fs::remove_dir_all(&tmp);
    let result = (|| {
        std::fs::create_dir_all(&tmp).map_err(|e| write_err(&tmp, e))?;
        let value = fill(&tmp)?;
        if out.exists() {
            std::fs::remove_dir_all(out).map_err(|e| write_err(out, e))?;
        }
        std::fs::rename(&tmp, out).map_err(|e| write_err(out, e))?;
        Ok(value)
    })();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

/// Write `path` through `fill` on a temporary file beside it, then rename; the temporary file is
/// removed on any failure. Returns the bytes written.
///
/// # Errors
/// `fill`'s error or [`FormatError::Write`].
pub fn write_atomic_with<F>(path: &Path, fill: F) -> Result<u64, FormatError>
where
    F: FnOnce(&mut BufWriter<std::fs::File>) -> Result<(), FormatError>,
{
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| write_err(parent, e))?;
    }
    let tmp = tmp_path(path);
    let result = (|| {
        let file = std::fs::File::create(&tmp).map_err(|e| write_err(&tmp, e))?;
        let mut w = BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| write_err(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| write_err(&tmp, e))?;
        let bytes = file.metadata().map_err(|e| write_err(&tmp, e))?.len();
        std::fs::rename(&tmp, path).map_err(|e| write_err(path, e))?;
        Ok(bytes)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
