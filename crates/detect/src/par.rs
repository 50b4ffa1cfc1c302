//! When to hand work to rayon: only when the pool has more than one thread. With a single thread
//! the caller (not a pool worker) would inject the job and sleep until that worker finishes,
//! which costs a thread wake-up per call (about 0.1 ms) and gains nothing.

/// Pixel count above which the image filters run their rows in parallel.
pub const PARALLEL_MIN_PIXELS: usize = 200_000;

/// True when `work` units (at least `min_work`) are worth splitting over rayon's pool, i.e. the
/// pool has more than one thread.
pub fn worth_parallel(work: usize, min_work: usize) -> bool {
    work >= min_work && rayon::current_num_threads() > 1
}

/// `f(0), f(1), ..., f(n - 1)` in order, over rayon's pool when `n` is at least `min_work`
/// ([`worth_parallel`]).
pub fn map_indexed<T: Send>(n: usize, min_work: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    use rayon::prelude::*;
    if worth_parallel(n, min_work) {
        (0..n).into_par_iter().map(f).collect()
    } else {
        (0..n).map(f).collect()
    }
}
