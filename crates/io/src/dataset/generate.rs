//! Dataset generation: render the images of one shard of a [`DatasetPlan`] into
//! `DIR/images/000123.png` + `DIR/images/000123.json` (a rig: `DIR/images/<camera>/000123.png`,
//! every camera of frame k from the same target pose), resumably, and write the shard's manifest.
//!
//! - Shard `I/N` renders the k with `k % N == I`; image k is the same in every shard layout and
//!   every run (its pose and noise seed depend only on the spec's seed and k).
//! - One thread renders (the GPU serialises frames anyway) and feeds `jobs` worker threads that
//!   compute the truth labels, encode the PNG, hash it and write both files atomically.
//! - Resume: an image whose PNG decodes completely at the camera's size and whose truth JSON
//!   parses is kept (the atomic rename means a crash leaves either the whole file or none; a
//!   damaged copy fails to decode and is redone). Leftover temporary files (`.000123.png.tmpPID`)
//!   of this shard's images are deleted first.
//! - `DIR/spec.toml` holds a copy of the spec; a folder holding another spec is refused.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

use rayon::prelude::*;

use super::manifest::{manifest_text, sha256_hex, shard_manifest_name};
use super::poses::{check_feasible, sample_view, SampledView};
use shots::{entries_of, image_dirs, shot_file, Shot, Written};

mod shots;
pub use super::shard::Shard;
use super::spec::DatasetPlan;
use super::{encode_image, io::truth_json, write_atomic, write_png_and_json, DatasetError};
use synthcam_render::Renderer;
use synthcam_scene::effects::Encoding;
use synthcam_scene::truth::truth_labels;
use synthcam_scene::Scene;

/// The spec copy in a dataset folder.
pub const SPEC_COPY: &str = "spec.toml";

/// Where and how to generate.
#[derive(Debug, Clone)]
pub struct GenerateParams {
    /// Dataset folder.
    pub out_dir: PathBuf,
    /// The spec text, copied to `out_dir/spec.toml`.
    pub spec_text: String,
    /// Which images.
    pub shard: Shard,
    /// Encoding and writing threads (>= 1), besides the render thread.
    pub jobs: usize,
}

/// Summed time per stage, seconds (stages overlap across threads, so the sum exceeds the wall time).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Pose sampling and the resume check (decoding existing files).
    pub prepare_s: f64,
    /// GPU render including readback (the render thread), and the image formation after it:
    /// blur, vignetting, noise or the sensor, quantisation (the encoding threads).
    pub render_s: f64,
    /// Truth labels.
    pub truth_s: f64,
    /// PNG encoding.
    pub encode_s: f64,
    /// JSON serialisation, hashing and the atomic writes.
    pub write_s: f64,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateReport {
    /// Images of this shard.
    pub images: u64,
    /// Kept from an earlier run.
    pub kept: u64,
    /// Rendered now.
    pub rendered: u64,
    /// Leftover temporary files deleted.
    pub removed_tmp: u64,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// Stage times.
    pub times: StageTimes,
    /// The shard's manifest.
    pub manifest: PathBuf,
}

/// Progress after each finished image: (done, total) of this shard, kept images included.
pub type ProgressFn<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// Name of image k's PNG, relative to the dataset folder.
pub fn image_file(k: u64) -> String {
    image_file_as(k, Encoding::Png)
}

/// Name of image k, relative to the dataset folder, for the spec's `[output] encoding`
/// (`.png` or `.jpg`).
pub fn image_file_as(k: u64, encoding: Encoding) -> String {
    match encoding {
        Encoding::Png => format!("images/{k:06}.png"),
        Encoding::Jpeg => format!("images/{k:06}.jpg"),
    }
}

fn write_err(path: &Path, source: std::io::Error) -> DatasetError {
    DatasetError::Write { path: path.display().to_string(), source }
}

/// Create the folder and its `spec.toml` copy (refusing a folder that holds another spec).
fn prepare_folder(plan: &DatasetPlan, params: &GenerateParams) -> Result<(), DatasetError> {
    for images in image_dirs(plan, &params.out_dir) {
        std::fs::create_dir_all(&images).map_err(|e| write_err(&images, e))?;
    }
    let copy = params.out_dir.join(SPEC_COPY);
    match std::fs::read_to_string(&copy) {
        Ok(existing) if existing == params.spec_text => Ok(()),
        Ok(_) => Err(DatasetError::SpecMismatch { path: copy.display().to_string() }),
        Err(_) => write_atomic(&copy, params.spec_text.as_bytes()),
    }
}

/// Delete leftover temporary files (`.000123.png.tmpPID`) of this shard's images.
fn remove_leftovers(images: &Path, shard: Shard) -> Result<u64, DatasetError> {
    let mut removed = 0;
    for entry in std::fs::read_dir(images).map_err(|e| DatasetError::Read { path: images.display().to_string(), reason: e.to_string() })?.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = name.strip_prefix('.') else { continue };
        if !rest.contains(".tmp") {
            continue;
        }
        let Ok(k) = rest.chars().take_while(char::is_ascii_digit).collect::<String>().parse::<u64>() else { continue };
        if shard.contains(k) {
            std::fs::remove_file(entry.path()).map_err(|e| write_err(&entry.path(), e))?;
            removed += 1;
        }
    }
    Ok(removed)
}

/// The encoded bytes of `file` when it decodes completely at `size` and its JSON parses.
fn existing_png(dir: &Path, file: &str, size: (u32, u32)) -> Option<Vec<u8>> {
    let png_path = dir.join(file);
    let png = std::fs::read(&png_path).ok()?;
    let json = std::fs::read(png_path.with_extension("json")).ok()?;
    serde_json::from_slice::<serde_json::Value>(&json).ok()?;
    let img = image::load_from_memory(&png).ok()?;
    ((img.width(), img.height()) == size).then_some(png)
}

/// Form (`synthcam_render::finish`: blur, vignetting, noise or sensor, quantisation), encode and
/// write one rendered image from its radiance.
fn finish_image(
    dir: &Path,
    file: String,
    shot: Shot<'_>,
    scene: &Scene,
    radiance: &[f32],
    extras: [bool; 2],
    times: &Mutex<StageTimes>,
) -> Result<Written, DatasetError> {
    let tf = Instant::now();
    let img = &synthcam_render::finish(scene, radiance).map_err(|e| DatasetError::Render { k: shot.view.k, reason: e.to_string() })?;
    let t0 = Instant::now();
    let truth = truth_labels(scene);
    let t1 = Instant::now();
    let output = scene.render.effects.output;
    let png = encode_image(img, &output)?;
    let t2 = Instant::now();
    let json = truth_json(&truth)?;
    let path = dir.join(&file);
    if extras.iter().any(|e| *e) {
        super::extras::write_extras(&path, &synthcam_scene::depth::depth_mask(scene), extras[0], extras[1])?;
    }
    write_png_and_json(&path, &png, &json)?;
    let written = Written { k: shot.view.k, cam: shot.cam, file, sha256: sha256_hex(&png) };
    let t3 = Instant::now();
    if let Ok(mut t) = times.lock() {
        t.render_s += (t0 - tf).as_secs_f64();
        t.truth_s += (t1 - t0).as_secs_f64();
        t.encode_s += (t2 - t1).as_secs_f64();
        t.write_s += (t3 - t2).as_secs_f64();
    }
    Ok(written)
}

/// Generate one shard of `plan` (see the module docs).
///
/// # Errors
/// An infeasible pose constraint (before anything is written), a folder holding another spec,
/// a render failure or a write failure (no partial file is left behind).
pub fn generate(renderer: &Renderer, plan: &DatasetPlan, params: &GenerateParams, progress: ProgressFn<'_>) -> Result<GenerateReport, DatasetError> {
    let wall = Instant::now();
    if params.shard.count == 0 || params.shard.index >= params.shard.count {
        return Err(DatasetError::InvalidArgument {
            what: "shard".into(),
            reason: format!("{}/{}: need 0 <= index < count", params.shard.index, params.shard.count),
        });
    }
    check_feasible(plan)?;
    let ks: Vec<u64> = (0..plan.count).filter(|k| params.shard.contains(*k)).collect();
    let views: Vec<SampledView> = ks.par_iter().map(|k| sample_view(plan, *k)).collect::<Result<_, _>>()?;
    prepare_folder(plan, params)?;
    let dir = params.out_dir.as_path();
    let mut removed_tmp = 0;
    for images in image_dirs(plan, dir) {
        removed_tmp += remove_leftovers(&images, params.shard)?;
    }
    let cams: Vec<Option<usize>> = if plan.rig.is_empty() { vec![None] } else { (0..plan.rig.len()).map(Some).collect() };
    let shots: Vec<Shot<'_>> = views.iter().flat_map(|view| cams.iter().map(move |&cam| Shot { view, cam })).collect();
    let size_of = |cam: Option<usize>| {
        let c = cam.and_then(|i| plan.rig.get(i)).map_or(plan.camera, |m| m.camera);
        (c.size.width, c.size.height)
    };
    let existing: Vec<Option<Written>> = shots
        .par_iter()
        .map(|s| {
            let file = shot_file(plan, s.view.k, s.cam);
            let png = existing_png(dir, &file, size_of(s.cam))?;
            Some(Written { k: s.view.k, cam: s.cam, file, sha256: sha256_hex(&png) })
        })
        .collect();
    let mut written: Vec<Written> = Vec::with_capacity(shots.len());
    let mut todo: Vec<Shot<'_>> = Vec::new();
    for (s, w) in shots.iter().zip(existing) {
        match w {
            Some(w) => written.push(w),
            None => todo.push(*s),
        }
    }
    let kept = written.len() as u64;
    let total = shots.len() as u64;
    let times = Mutex::new(StageTimes { prepare_s: wall.elapsed().as_secs_f64(), ..Default::default() });
    progress(kept, total);
    written.extend(render_all(renderer, plan, dir, &todo, params.jobs, &times, &|n| progress(n, total), kept)?);
    let rendered = todo.len() as u64;
    let manifest = dir.join(shard_manifest_name(params.shard.index, params.shard.count));
    write_atomic(&manifest, manifest_text(&entries_of(plan, &views, &written))?.as_bytes())?;
    let times = times.into_inner().unwrap_or_default();
    Ok(GenerateReport { images: total, kept, rendered, removed_tmp, wall_s: wall.elapsed().as_secs_f64(), times, manifest })
}

/// Render `todo` on this thread (the radiance: GPU work and readback) and form, encode and write
/// the images on `jobs` threads (a bounded channel between them), so that the noise and the
/// quantisation of one image overlap the next one's render; `progress` gets the count done,
/// counting from `done_before`. The first failure stops the run and is returned.
#[allow(clippy::too_many_arguments)] // the run's pieces, each used once; a struct would only rename them
fn render_all(
    renderer: &Renderer,
    plan: &DatasetPlan,
    dir: &Path,
    todo: &[Shot<'_>],
    jobs: usize,
    times: &Mutex<StageTimes>,
    progress: &(dyn Fn(u64) + Sync),
    done_before: u64,
) -> Result<Vec<Written>, DatasetError> {
    let done = std::sync::atomic::AtomicU64::new(done_before);
    let results: Mutex<Vec<Written>> = Mutex::new(Vec::with_capacity(todo.len()));
    let failure: Mutex<Option<DatasetError>> = Mutex::new(None);
    let failed = || failure.lock().map(|f| f.is_some()).unwrap_or(true);
    let fail = |e: DatasetError| {
        if let Ok(mut f) = failure.lock() {
            f.get_or_insert(e);
        }
    };
    let jobs = jobs.max(1);
    let (tx, rx) = std::sync::mpsc::sync_channel::<(Shot<'_>, Scene, Vec<f32>)>(2 * jobs);
    let rx = Mutex::new(rx);
    std::thread::scope(|s| {
        for _ in 0..jobs {
            s.spawn(|| loop {
                let msg = match rx.lock() {
                    Ok(r) => r.recv(),
                    Err(_) => return,
                };
                let Ok((shot, scene, img)) = msg else { return };
                if failed() {
                    continue;
                }
                match finish_image(dir, shot_file(plan, shot.view.k, shot.cam), shot, &scene, &img, plan.extras, times) {
                    Ok(e) => {
                        if let Ok(mut r) = results.lock() {
                            r.push(e);
                        }
                        progress(done.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1);
                    }
                    Err(e) => fail(e),
                }
            });
        }
        for shot in todo {
            if failed() {
                break;
            }
            let scene = shot.scene(plan);
            let t0 = Instant::now();
            let img = match renderer.render_radiance(&scene) {
                Ok(img) => img,
                Err(e) => {
                    fail(DatasetError::Render { k: shot.view.k, reason: e.to_string() });
                    break;
                }
            };
            if let Ok(mut t) = times.lock() {
                t.render_s += t0.elapsed().as_secs_f64();
            }
            if tx.send((*shot, scene, img)).is_err() {
                break;
            }
        }
        drop(tx);
    });
    if let Some(e) = failure.into_inner().ok().flatten() {
        return Err(e);
    }
    Ok(results.into_inner().unwrap_or_default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leftovers_of_this_shard_only_are_removed() {
        let dir = std::env::temp_dir().join(format!("synthcam-leftovers-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for n in [".000001.png.tmp12", ".000002.json.tmp7", "000001.png", ".hidden"] {
            std::fs::write(dir.join(n), b"x").unwrap();
        }
        let removed = remove_leftovers(&dir, Shard { index: 1, count: 2 }).unwrap();
        assert_eq!(removed, 1);
        assert!(!dir.join(".000001.png.tmp12").exists());
        assert!(dir.join(".000002.json.tmp7").exists() && dir.join("000001.png").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
