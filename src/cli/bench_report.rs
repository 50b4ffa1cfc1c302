//! `synthcam bench --report`: the renderer's table (issue 42): frames/s of each kind of scene at
//! 1280 x 1024 and at three times the pixels along each axis (3840 x 3072, the same view), dataset
//! images/s and the IBVS loop's steps/s, headed by the adapter's name. `--out DIR` keeps every
//! scene's image and the figures (`report.json`); `--compare DIR` checks this run's images against
//! another run's, such as a GPU's against lavapipe's on the same machine (`benches/gpu.sh`).

use std::path::{Path, PathBuf};

use anyhow::Context;
use synthcam::dataset::generate::{generate, GenerateParams};
use synthcam::dataset::shard::Shard;
use synthcam::render::{GreyImage, Renderer};
use synthcam::scene::file::parse_scene;
use synthcam::scene::Scene;

/// The scenes of the table: name, scene file, whether it is also timed at 3x (the effects scenes
/// are stated in physical units and kept at their size), whether the benchmark mesh (100 820
/// triangles) stands in front of the board.
const SCENES: [(&str, &str, bool, bool); 7] = [
    ("chessboard", include_str!("../../assets/scenes/chessboard_k1.toml"), true, false),
    ("charuco", include_str!("../../assets/scenes/charuco_k1.toml"), true, false),
    ("s_path", include_str!("../../assets/scenes/course_s_path.toml"), true, false),
    ("fisheye", include_str!("../../assets/scenes/fisheye_wide_chessboard.toml"), true, false),
    ("mesh_100k", include_str!("../../assets/scenes/chessboard_k1.toml"), true, true),
    ("defocus_16", include_str!("../../assets/scenes/effects/defocus.toml"), false, false),
    ("motion_16", include_str!("../../assets/scenes/effects/motion_blur.toml"), false, false),
];

/// The dataset the table times (`assets/specs/chessboard_1280.toml`, its first images).
const DATASET_SPEC: &str = include_str!("../../assets/specs/chessboard_1280.toml");

/// Options of the report.
#[derive(Debug, Clone)]
pub struct ReportOptions {
    /// Timed frames per scene (after 3 untimed).
    pub frames: usize,
    /// Dataset images to generate.
    pub dataset_images: u64,
    /// IBVS loop steps.
    pub servo_steps: usize,
    /// Where to keep the images and `report.json`.
    pub out: Option<PathBuf>,
    /// Another run's `--out` folder to compare the images with.
    pub compare: Option<PathBuf>,
}

/// One scene's row.
#[derive(Debug, Clone, serde::Serialize)]
struct Row {
    scene: String,
    width: u32,
    height: u32,
    median_ms: f64,
    frames_per_s: f64,
    /// Against the reference run: the largest difference, grey levels, and the pixels that differ.
    vs_reference: Option<(u16, usize)>,
}

/// The whole report (`report.json`).
#[derive(Debug, Clone, serde::Serialize)]
struct Report {
    adapter: String,
    driver: String,
    rows: Vec<Row>,
    dataset_images: u64,
    dataset_images_per_s: f64,
    servo_steps: usize,
    servo_steps_per_s: f64,
    servo_render_ms_per_step: f64,
    servo_detect_ms_per_step: f64,
}

/// Render + readback and quantise + PNG times of `frames` renders (after 3 untimed), each sorted,
/// milliseconds, and the finished image of the last one.
pub fn time_frames(renderer: &Renderer, scene: &Scene, frames: usize) -> anyhow::Result<(Vec<f64>, Vec<f64>, GreyImage)> {
    for _ in 0..3 {
        renderer.render_radiance(scene)?;
    }
    let (mut render_ms, mut post_ms, mut last) = (Vec::new(), Vec::new(), None);
    for _ in 0..frames.max(1) {
        let t0 = std::time::Instant::now();
        let linear = renderer.render_radiance(scene)?;
        let t1 = std::time::Instant::now();
        let img = synthcam::render::finish(scene, &linear)?;
        let _png = synthcam::dataset::encode_png(&img)?;
        render_ms.push((t1 - t0).as_secs_f64() * 1e3);
        post_ms.push(t1.elapsed().as_secs_f64() * 1e3);
        last = Some(img);
    }
    render_ms.sort_by(f64::total_cmp);
    post_ms.sort_by(f64::total_cmp);
    Ok((render_ms, post_ms, last.context("no frame rendered")?))
}

/// The `p` quantile of `sorted` (the nearest rank), NaN when empty.
pub fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// The scenes at their size and, where asked, at 3x.
fn scenes() -> anyhow::Result<Vec<(String, Scene)>> {
    let mut out = Vec::new();
    for (name, text, scaled, mesh) in SCENES {
        let scene = if mesh { synthcam::scene::objects::with_benchmark_mesh(parse_scene(text))? } else { parse_scene(text)? };
        if scaled {
            let big = Scene { camera: scene.camera.scaled(3.0)?, ..scene.clone() };
            out.push((name.to_string(), scene));
            out.push((name.to_string(), big));
        } else {
            out.push((name.to_string(), scene));
        }
    }
    Ok(out)
}

/// The largest difference (grey levels) and the number of differing pixels between `image` and
/// the reference PNG `path`.
fn compare_with(image: &GreyImage, path: &Path) -> anyhow::Result<(u16, usize)> {
    let reference = GreyImage::from(image::open(path).with_context(|| format!("reading the reference {}", path.display()))?);
    anyhow::ensure!(reference.dimensions() == image.dimensions(), "{}: {:?}, not {:?}", path.display(), reference.dimensions(), image.dimensions());
    let (a, b) = (image.to_u8(), reference.to_u8());
    let diffs = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).filter(|d| *d > 0);
    Ok(diffs.fold((0u16, 0usize), |(m, n), d| (m.max(u16::from(d)), n + 1)))
}

/// The dataset's images/s: the first `n` images of the spec into a temporary folder, 2 encoding jobs.
fn dataset_rate(renderer: &Renderer, n: u64) -> anyhow::Result<f64> {
    let mut plan = synthcam::dataset::spec::parse_dataset_spec(DATASET_SPEC)?;
    plan.count = n.max(1);
    let dir = std::env::temp_dir().join(format!("synthcam-bench-report-{}", std::process::id()));
    let params = GenerateParams { out_dir: dir.clone(), spec_text: DATASET_SPEC.to_string(), shard: Shard::ALL, jobs: 2 };
    let report = generate(renderer, &plan, &params, &|_, _| {});
    let _ = std::fs::remove_dir_all(&dir);
    let report = report?;
    Ok(report.rendered as f64 / report.wall_s.max(1e-9))
}

/// Run the report.
pub fn run(renderer: &Renderer, opts: &ReportOptions) -> anyhow::Result<()> {
    let info = &renderer.context().adapter_info;
    let mut rows = Vec::new();
    for (name, scene) in scenes()? {
        let (w, h) = (scene.camera.size.width, scene.camera.size.height);
        let (render_ms, _, image) = time_frames(renderer, &scene, opts.frames).with_context(|| format!("scene {name} {w}x{h}"))?;
        let ms = percentile(&render_ms, 0.5);
        let file = format!("{name}_{w}x{h}.png");
        if let Some(dir) = &opts.out {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            synthcam::dataset::write_atomic(&dir.join(&file), &synthcam::dataset::encode_png(&image)?)?;
        }
        let vs_reference = opts.compare.as_ref().map(|d| compare_with(&image, &d.join(&file))).transpose()?;
        rows.push(Row { scene: name, width: w, height: h, median_ms: ms, frames_per_s: 1e3 / ms, vs_reference });
    }
    let dataset_images_per_s = dataset_rate(renderer, opts.dataset_images)?;
    let trace = super::bench::ibvs_loop(renderer, opts.servo_steps)?;
    let (r, d, _) = trace.time_split_ms();
    let n = trace.steps.len().max(1) as f64;
    let report = Report {
        adapter: format!("{} / {:?}", info.name, info.backend),
        driver: format!("{} {}", info.driver, info.driver_info).trim().to_string(),
        rows,
        dataset_images: opts.dataset_images,
        dataset_images_per_s,
        servo_steps: trace.steps.len(),
        servo_steps_per_s: n / trace.loop_s.max(1e-9),
        servo_render_ms_per_step: r / n,
        servo_detect_ms_per_step: d / n,
    };
    print_table(&report, opts.compare.is_some());
    if let Some(dir) = &opts.out {
        synthcam::dataset::write_atomic(&dir.join("report.json"), &serde_json::to_vec_pretty(&report)?)?;
    }
    Ok(())
}

fn print_table(r: &Report, compared: bool) {
    println!("adapter: {} (driver: {})\n", r.adapter, if r.driver.is_empty() { "-" } else { &r.driver });
    println!("| scene | size | render + readback, median ms | frames/s |{}", if compared { " vs reference |" } else { "" });
    println!("|---|---|---|---|{}", if compared { "---|" } else { "" });
    for row in &r.rows {
        let vs = match row.vs_reference {
            Some((0, _)) => " identical |".to_string(),
            Some((max, n)) => format!(" {n} pixels differ, by <= {max} grey levels |"),
            None => String::new(),
        };
        println!("| {} | {} x {} | {:.1} | {:.1} |{vs}", row.scene, row.width, row.height, row.median_ms, row.frames_per_s);
    }
    println!(
        "| dataset chessboard_1280 ({} images, 2 jobs, PNG + truth) | 1280 x 1024 | | {:.1} images/s |{}",
        r.dataset_images,
        r.dataset_images_per_s,
        if compared { " |" } else { "" }
    );
    println!(
        "| IBVS loop, course ({} steps: render {:.1} + detect {:.1} ms/step) | 1280 x 1024 | | {:.1} steps/s |{}",
        r.servo_steps,
        r.servo_render_ms_per_step,
        r.servo_detect_ms_per_step,
        r.servo_steps_per_s,
        if compared { " |" } else { "" }
    );
}
