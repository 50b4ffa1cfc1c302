//! The random streams of a dataset: image k's draws (pose, occluders, noise seed) depend only on
//! the spec's seed and k, so shards and reruns give the same images.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The generator of image k: ChaCha8 keyed by `seed`, stream `k`.
pub fn image_rng(seed: u64, k: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(k);
    rng
}
