//! Put your own mesh in front of a calibration board, render it, and read the occlusion truth,
//! depth and instance mask: the library calls behind `synthcam render --depth --mask`.
//!
//! `cargo run --release --example occluded_board [OUT_DIR]` (default `out/occluded_board`).

use std::path::{Path, PathBuf};

use synthcam::dataset::extras::{encode_mask_png, encode_npy_f32};
use synthcam::dataset::{encode_png, write_atomic, MeshLibrary};
use synthcam::nalgebra::{Isometry3, Vector3};
use synthcam::render::Renderer;
use synthcam::scene::depth::depth_mask;
use synthcam::scene::file::parse_scene;
use synthcam::scene::objects::{SceneObject, Shading};
use synthcam::scene::truth_labels;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map_or_else(|| PathBuf::from("out/occluded_board"), PathBuf::from);
    std::fs::create_dir_all(&out)?;
    // The ChArUco scene of the README, and the project's gripper mesh (any OBJ file works).
    let mut scene = parse_scene(include_str!("../assets/scenes/charuco_k1.toml"))?;
    let gripper = MeshLibrary::new(Path::new(".")).load(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/meshes/gripper.obj"))?;
    let mut object = SceneObject::new(gripper, Isometry3::new(Vector3::new(0.01, 0.03, 0.32), Vector3::new(1.2, 0.0, 0.5)));
    object.shading = Shading::HeadLight;
    scene.objects.push(object);

    let image = Renderer::headless()?.render(&scene)?;
    let truth = truth_labels(&scene);
    let maps = depth_mask(&scene);
    write_atomic(&out.join("image.png"), &encode_png(&image)?)?;
    write_atomic(&out.join("depth.npy"), &encode_npy_f32(maps.width, maps.height, &maps.depth_m))?;
    write_atomic(&out.join("mask.png"), &encode_mask_png(&maps)?)?;
    let hidden = truth.features.iter().filter(|f| f.occluded).count();
    let gripper_px = maps.instance.iter().filter(|&&id| id == 2).count();
    println!("{} of {} corners hidden by the gripper; it covers {gripper_px} pixels; wrote {}", hidden, truth.features.len(), out.display());
    Ok(())
}
