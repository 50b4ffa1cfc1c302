//! Per-thread reuse of large f32 sample buffers (pyramid levels, smoothed images, response
//! maps). A fresh multi-megabyte allocation is handed out as untouched pages, so every detection
//! would otherwise pay a page fault per 4 KiB written (measured: about a third of the chessboard
//! detector's time at 1280 x 1024); a dropped [`ImageF32`](super::ImageF32) returns its buffer
//! here and the next detection on the same thread takes it back.
//!
//! Bounded: at most [`MAX_BUFFERS`] buffers and [`MAX_TOTAL_SAMPLES`] samples per thread; smaller
//! buffers than [`MIN_SAMPLES`] are left to the allocator.

use std::cell::RefCell;

/// Buffers with fewer samples than this (128 KiB) are not pooled.
pub const MIN_SAMPLES: usize = 1 << 15;
/// At most this many buffers are kept per thread.
pub const MAX_BUFFERS: usize = 8;
/// At most this many samples (64 MiB) are kept per thread.
pub const MAX_TOTAL_SAMPLES: usize = 1 << 24;

thread_local! {
    static POOL: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `len` zeros: the smallest pooled one that is large enough, else a new one.
pub fn zeroed(len: usize) -> Vec<f32> {
    match take(len) {
        Some(mut v) => {
            v.clear();
            v.resize(len, 0.0);
            v
        }
        None => vec![0.0; len],
    }
}

/// A buffer of `len` samples with unspecified values (a reused buffer keeps an earlier image's
/// samples), for outputs that overwrite every sample: saves [`zeroed`]'s pass over the memory.
pub fn scratch(len: usize) -> Vec<f32> {
    match take(len) {
        Some(mut v) => {
            v.resize(len, 0.0);
            v.truncate(len);
            v
        }
        None => vec![0.0; len],
    }
}

/// The smallest pooled buffer with room for `len` samples, removed from the pool.
fn take(len: usize) -> Option<Vec<f32>> {
    if len >= MIN_SAMPLES {
        POOL.try_with(|p| {
            let mut p = p.try_borrow_mut().ok()?;
            let best = (0..p.len()).filter(|&i| p[i].capacity() >= len).min_by_key(|&i| p[i].capacity())?;
            Some(p.swap_remove(best))
        })
        .ok()
        .flatten()
    } else {
        None
    }
}

/// Keep `v` for a later [`zeroed`] when it is large and the pool has room (else drop it).
pub fn recycle(v: Vec<f32>) {
    if v.capacity() < MIN_SAMPLES {
        return;
    }
    let _ = POOL.try_with(|p| {
        if let Ok(mut p) = p.try_borrow_mut() {
            let total: usize = p.iter().map(Vec::capacity).sum();
            if p.len() < MAX_BUFFERS && total + v.capacity() <= MAX_TOTAL_SAMPLES {
                p.push(v);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reuses_large_buffers_zeroed_and_bounds_the_pool() {
        let mut v = zeroed(MIN_SAMPLES + 10);
        v.iter_mut().for_each(|x| *x = 3.0);
        let ptr = v.as_ptr();
        recycle(v);
        let w = zeroed(MIN_SAMPLES);
        assert_eq!(w.as_ptr(), ptr);
        assert!(w.len() == MIN_SAMPLES && w.iter().all(|x| *x == 0.0));
        recycle(w);
        assert_eq!(scratch(MIN_SAMPLES + 20).len(), MIN_SAMPLES + 20);
        // small buffers are not pooled; the count is bounded
        recycle(vec![1.0; 10]);
        for _ in 0..MAX_BUFFERS + 3 {
            recycle(vec![0.0; MIN_SAMPLES]);
        }
        assert_eq!(POOL.with_borrow(|p| p.len()), MAX_BUFFERS);
        assert!(zeroed(5).capacity() < MIN_SAMPLES);
    }
}
