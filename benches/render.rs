#![allow(missing_docs)]
//! Criterion benchmark of the renderer: render + readback of the embedded scenes (1280 x 1024),
//! the figure the speed goals are stated in. `cargo bench --bench render`.

use criterion::{criterion_group, criterion_main, Criterion};
use synthcam::render::{GpuContext, Renderer};
use synthcam::scene::file::parse_scene;

fn bench_render(c: &mut Criterion) {
    let renderer = match GpuContext::new_headless() {
        Ok(ctx) => Renderer::new(ctx),
        Err(e) => panic!("no GPU adapter: {e}"),
    };
    let scenes =
        [("chessboard_k1", include_str!("../assets/scenes/chessboard_k1.toml")), ("course_s_path", include_str!("../assets/scenes/course_s_path.toml"))];
    let mut group = c.benchmark_group("render+readback 1280x1024");
    group.sample_size(30);
    for (name, text) in scenes {
        let scene = match parse_scene(text) {
            Ok(s) => s,
            Err(e) => panic!("{name}: {e}"),
        };
        group.bench_function(name, |b| b.iter(|| renderer.render_linear(&scene).map(|v| v.len()).unwrap_or(0)));
    }
    // Issue 19's speed goal: the chessboard scene plus a 100 820-triangle icosphere in front of it.
    let scene = match synthcam::scene::objects::with_benchmark_mesh(parse_scene(scenes[0].1)) {
        Ok(s) => s,
        Err(e) => panic!("mesh scene: {e}"),
    };
    group.bench_function("chessboard_k1_mesh_100k", |b| b.iter(|| renderer.render_linear(&scene).map(|v| v.len()).unwrap_or(0)));
    group.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
