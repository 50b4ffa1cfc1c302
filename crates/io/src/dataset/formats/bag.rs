//! Where a ROS 2 bag goes: one MCAP file, or a rosbag2 folder (`metadata.yaml` beside
//! `<folder>_0.mcap`) that `ros2 bag info DIR` / `ros2 bag play DIR` and rosbags' `AnyReader`
//! open as a directory.
//!
//! `metadata.yaml` is rosbag2's format version 5 (what ROS 2 Humble writes; Iron, Jazzy and rosbags
//! read it): storage `mcap` (Humble reads it with `ros-humble-rosbag2-storage-mcap`, later releases
//! by default), no compression, every topic `cdr` with the default QoS. It is written here by hand
//! rather than through a YAML crate: a fixed document of constant topic names and numbers (the
//! Rust YAML serialisers are unmaintained), checked by rosbags' reader in `python/tests`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::mcap::{write_series, McapCounts, SeriesFrame, CAMERA_INFO_TOPIC, IMAGE_TOPIC, TF_TOPIC};
use super::ros2_msgs::{CAMERA_INFO_SCHEMA, IMAGE_SCHEMA, TF_SCHEMA};
use super::{write_atomic_with, write_folder_atomic, FormatError};
use synthcam_scene::file::CameraSpec;

/// rosbag2's metadata format version written.
pub const METADATA_VERSION: u32 = 5;

/// Where a bag is written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BagOutput {
    /// One `.mcap` file.
    File(PathBuf),
    /// A rosbag2 folder: `metadata.yaml` and `<folder name>_0.mcap`.
    Rosbag2(PathBuf),
}

impl BagOutput {
    /// The file or folder.
    pub fn path(&self) -> &Path {
        match self {
            BagOutput::File(p) | BagOutput::Rosbag2(p) => p,
        }
    }
}

/// The MCAP file's name inside a rosbag2 folder `dir` (`<folder name>_0.mcap`, as `ros2 bag record`
/// names its first file).
pub fn rosbag2_file_name(dir: &Path) -> String {
    let stem = dir.file_name().map_or_else(|| "bag".to_owned(), |n| n.to_string_lossy().into_owned());
    format!("{stem}_0.mcap")
}

/// rosbag2's `metadata.yaml` for one MCAP file `file_name` holding `counts`.
pub fn metadata_yaml(file_name: &str, counts: &McapCounts) -> String {
    let total = counts.images + counts.camera_infos + counts.tf;
    let (start, duration) = if total == 0 { (0, 0) } else { (counts.start_ns, counts.end_ns.saturating_sub(counts.start_ns)) };
    let mut y = String::new();
    let _ = writeln!(y, "rosbag2_bagfile_information:\n  version: {METADATA_VERSION}\n  storage_identifier: mcap");
    let _ = writeln!(y, "  duration:\n    nanoseconds: {duration}\n  starting_time:\n    nanoseconds_since_epoch: {start}");
    let _ = writeln!(y, "  message_count: {total}\n  topics_with_message_count:");
    for (topic, kind, n) in
        [(IMAGE_TOPIC, IMAGE_SCHEMA, counts.images), (CAMERA_INFO_TOPIC, CAMERA_INFO_SCHEMA, counts.camera_infos), (TF_TOPIC, TF_SCHEMA, counts.tf)]
    {
        let _ = writeln!(
            y,
            "    - topic_metadata:\n        name: {topic}\n        type: {kind}\n        serialization_format: cdr\n        offered_qos_profiles: \"\"\n      message_count: {n}"
        );
    }
    let _ = writeln!(y, "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - {file_name}\n  files:");
    let _ = writeln!(
        y,
        "    - path: {file_name}\n      starting_time:\n        nanoseconds_since_epoch: {start}\n      duration:\n        nanoseconds: {duration}"
    );
    let _ = writeln!(y, "      message_count: {total}");
    y
}

/// Write `frames` seen by `camera` as a bag at `out`, atomically (a file through a temporary name,
/// a folder built beside it and renamed). Returns the counts and the bytes written.
///
/// # Errors
/// [`super::mcap::camera_info`]'s, the frames' or the writer's errors; a rosbag2 output that exists
/// and is not a rosbag2 folder. Nothing is left at `out` then.
pub fn write_bag<I>(out: &BagOutput, camera: &CameraSpec, frames: I) -> Result<(McapCounts, u64), FormatError>
where
    I: IntoIterator<Item = Result<SeriesFrame, FormatError>>,
{
    let info = super::mcap::camera_info(camera)?;
    let write_mcap = |path: &Path| {
        let mcap_err = |source| FormatError::Mcap { path: path.display().to_string(), source };
        let mut counts = McapCounts::default();
        let bytes = write_atomic_with(path, |w| {
            counts = write_series(w, &info, frames, &mcap_err)?;
            Ok(())
        })?;
        Ok((counts, bytes))
    };
    match out {
        BagOutput::File(path) => write_mcap(path),
        BagOutput::Rosbag2(dir) => {
            // Ours to replace: a folder of a metadata.yaml and MCAP files only (as the WebDataset
            // export replaces only a folder of its shards), never one that holds anything else.
            let is_bag = |p: &Path| {
                p.join("metadata.yaml").is_file()
                    && std::fs::read_dir(p)
                        .is_ok_and(|d| d.flatten().all(|e| e.file_name() == "metadata.yaml" || e.path().extension().is_some_and(|x| x == "mcap")))
            };
            write_folder_atomic(dir, "a rosbag2 folder", is_bag, |tmp| {
                let name = rosbag2_file_name(dir);
                let (counts, bytes) = write_mcap(&tmp.join(&name))?;
                let yaml = metadata_yaml(&name, &counts);
                let meta =
                    write_atomic_with(&tmp.join("metadata.yaml"), |w| std::io::Write::write_all(w, yaml.as_bytes()).map_err(|e| super::write_err(tmp, e)))?;
                Ok((counts, bytes + meta))
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_counts_every_topic_and_spans_first_to_last_stamp() {
        let counts = McapCounts { images: 3, camera_infos: 3, tf: 3, start_ns: 100, end_ns: 300 };
        let y = metadata_yaml("run_0.mcap", &counts);
        assert!(y.contains("  version: 5\n  storage_identifier: mcap\n"), "{y}");
        assert!(y.contains("  duration:\n    nanoseconds: 200\n  starting_time:\n    nanoseconds_since_epoch: 100\n  message_count: 9\n"), "{y}");
        assert!(y.contains("        name: /cam0/image_raw\n        type: sensor_msgs/msg/Image\n"), "{y}");
        assert!(y.contains("  relative_file_paths:\n    - run_0.mcap\n"), "{y}");
        assert_eq!(y.matches("message_count: 3").count(), 3);
        assert_eq!(rosbag2_file_name(Path::new("out/run")), "run_0.mcap");
    }
}
