//! WebDataset tar shards (<https://github.com/webdataset/webdataset>): `shard-000000.tar`, ...,
//! each a plain POSIX tar of samples `NNNNNN.png` (or `.jpg`) + `NNNNNN.json` (the truth JSON
//! as written) and, when the dataset has them, `NNNNNN.depth.npy` and `NNNNNN.mask.png`; the
//! sample key is the image index. A new shard starts before a sample that would take the
//! current one past the shard size (a sample larger than that gets a shard of its own). Entries
//! have mode 0644 and mtime 0, so the shards are byte-identical across runs.

use std::io::Write;
use std::path::Path;

use super::folder::DatasetFolder;
use super::{write_atomic_with, write_err, FormatError};

/// Name of shard `i`.
pub fn shard_name(i: usize) -> String {
    format!("shard-{i:06}.tar")
}

/// One file of a sample: name inside the tar, bytes.
pub type SampleFile = (String, Vec<u8>);

/// Bytes a file takes in a tar: a 512-byte header and the data padded to 512.
pub fn tar_entry_bytes(len: usize) -> u64 {
    512 + (len as u64).div_ceil(512) * 512
}

/// Append `files` to the tar `builder`.
///
/// # Errors
/// The writer's error.
pub fn append_sample<W: Write>(builder: &mut tar::Builder<W>, files: &[SampleFile]) -> std::io::Result<()> {
    for (name, bytes) in files {
        let mut header = tar::Header::new_ustar();
        header.set_size(bytes.len() as u64);
        header.set_mode(0o644);
        header.set_mtime(0);
        header.set_entry_type(tar::EntryType::Regular);
        builder.append_data(&mut header, name, bytes.as_slice())?;
    }
    Ok(())
}

/// Write samples into shards: `next(i)` gives sample i's files; a shard is closed when the
/// next sample would take it past `shard_bytes`. `open_shard(index, fill)` writes one shard
/// file through `fill`. Returns the shard count.
fn write_shards<N, O>(count: usize, shard_bytes: u64, next: N, mut open_shard: O) -> Result<usize, FormatError>
where
    N: Fn(usize) -> Result<Vec<SampleFile>, FormatError>,
    O: FnMut(usize, &mut dyn FnMut(&mut dyn Write) -> Result<(), FormatError>) -> Result<(), FormatError>,
{
    let mut i = 0;
    let mut shard = 0;
    while i < count {
        let mut fill = |w: &mut dyn Write| -> Result<(), FormatError> {
            let mut builder = tar::Builder::new(w);
            let mut used = 1024; // the end-of-archive blocks
            while i < count {
                let files = next(i)?;
                let size: u64 = files.iter().map(|(_, b)| tar_entry_bytes(b.len())).sum();
                if used > 1024 && used + size > shard_bytes {
                    break;
                }
                append_sample(&mut builder, &files).map_err(|e| write_err(Path::new(&shard_name(shard)), e))?;
                used += size;
                i += 1;
            }
            builder.finish().map_err(|e| write_err(Path::new(&shard_name(shard)), e))
        };
        open_shard(shard, &mut fill)?;
        shard += 1;
    }
    Ok(shard)
}

/// The files of dataset sample `e`: image, truth JSON, extras.
fn sample_files(folder: &DatasetFolder, e: &crate::dataset::manifest::ManifestEntry) -> Result<Vec<SampleFile>, FormatError> {
    let key = format!("{:06}", e.k);
    let ext = Path::new(&e.file).extension().and_then(|x| x.to_str()).unwrap_or("png");
    let mut files = vec![(format!("{key}.{ext}"), folder.read_image(e)?), (format!("{key}.json"), folder.read_truth_bytes(e)?)];
    for (extra, bytes) in folder.read_extras(e)? {
        files.push((format!("{key}.{extra}"), bytes));
    }
    Ok(files)
}

/// Write `folder` as shards into the folder `out`: first into a temporary folder beside it,
/// then renamed over `out` (an earlier `out` holding only shards is replaced). Returns (shards,
/// bytes).
///
/// # Errors
/// A read, corrupt-file or write error (the temporary folder is removed), or an `out` that
/// exists and holds other files.
pub fn write_folder(folder: &DatasetFolder, out: &Path, shard_bytes: u64, tick: super::Tick<'_>) -> Result<(u64, u64), FormatError> {
    let only_shards = |p: &Path| std::fs::read_dir(p).is_ok_and(|d| d.flatten().all(|e| e.file_name().to_string_lossy().starts_with("shard-")));
    super::write_folder_atomic(out, "a folder of WebDataset shards", only_shards, |tmp| {
        let (mut bytes, ticked) = (0, std::cell::Cell::new(0));
        let shards = write_shards(
            folder.entries.len(),
            shard_bytes,
            |i| {
                // A sample that does not fit is read again for the next shard: count it once.
                if i >= ticked.get() {
                    ticked.set(i + 1);
                    tick();
                }
                folder.entries.get(i).map_or_else(|| Ok(Vec::new()), |e| sample_files(folder, e))
            },
            |index, fill| {
                bytes += write_atomic_with(&tmp.join(shard_name(index)), |w| fill(w))?;
                Ok(())
            },
        )?;
        Ok((shards as u64, bytes))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_split_before_the_sample_that_would_overflow() {
        // Samples of 2 files of 1000 bytes: 2 * (512 + 1024) = 3072 tar bytes each.
        let mut shards: Vec<Vec<u8>> = Vec::new();
        let n = write_shards(
            5,
            1024 + 2 * 3072,
            |i| Ok(vec![(format!("{i:06}.png"), vec![1; 1000]), (format!("{i:06}.json"), vec![2; 1000])]),
            |_, fill| {
                let mut buf = Vec::new();
                fill(&mut buf)?;
                shards.push(buf);
                Ok(())
            },
        )
        .unwrap();
        assert_eq!(n, 3);
        let names: Vec<Vec<String>> = shards
            .iter()
            .map(|s| tar::Archive::new(s.as_slice()).entries().unwrap().map(|e| e.unwrap().path().unwrap().display().to_string()).collect())
            .collect();
        assert_eq!(names[0], ["000000.png", "000000.json", "000001.png", "000001.json"]);
        assert_eq!(names[2], ["000004.png", "000004.json"]);
    }
}
