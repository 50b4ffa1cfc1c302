//! Writes the committed mesh assets under `assets/meshes/` from their generators
//! ([`synthcam::mesh::primitives::assets`]): OBJ, MTL and, for the textured meshes, PNG. The unit
//! test `mesh::primitives::tests::assets_match_the_generators` fails when the files drift from
//! the generators; run this after an intended change.
//!
//! `cargo run --release --example make_meshes [OUT_DIR]` (default: the crate's `assets/meshes`).

use std::path::PathBuf;

use synthcam::mesh::primitives::assets;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets").join("meshes"), PathBuf::from);
    std::fs::create_dir_all(&out)?;
    for asset in assets() {
        for (file, bytes) in asset.files()? {
            let path = out.join(&file);
            std::fs::write(&path, &bytes)?;
            println!("{} ({} triangles): {} bytes", path.display(), asset.mesh.triangles.len(), bytes.len());
        }
    }
    Ok(())
}
