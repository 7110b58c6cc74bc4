//! Deterministic parallel loops: results bit for bit independent of the
//! number of threads, so a checkpoint resumes exactly on any machine.
//!
//! Work is cut into chunks of a fixed size ([`CHUNK`]), never into one
//! piece per thread; a sum adds each chunk's partial in chunk order. Which
//! thread runs a chunk then changes nothing. Loops shorter than
//! [`PARALLEL_MIN`] run on the calling thread (the same chunks, the same
//! sums): below it, handing work to another core costs more than it saves.
//! Neither do loops in a pool of one thread: handing work to a lone
//! worker only adds a wake-up per loop (5 % of a 30² run).
//!
//! The threads are rayon's global pool; callers size it once at start
//! (`drapery --threads`, `DRAPERY_THREADS`).

use std::ops::Range;

use rayon::prelude::*;

use crate::math::{Real, Vec3};

/// Elements per chunk.
pub const CHUNK: usize = 512;
/// Fewest elements worth spreading over threads: vector loops and the
/// block-sparse product. Since the solver runs on a pool thread (a
/// fork-join of two halves costs ~5 µs on the 2-core benchmark machine,
/// docs/benchmarks.md 1e), a 100² cloth's loops (10⁴ elements, 10–300 µs)
/// gain from the second core: its solve stage took 0.70 s at a threshold
/// of 32,768 and 0.45 s at 4,096 (with the sweeps' threshold lowered too,
/// docs/benchmarks.md 1g); at 60² a lower threshold gained nothing.
pub const PARALLEL_MIN: usize = 4096;
/// Fewest values of a [`for_rows`] table worth spreading when each is
/// a microsecond of work (a node's factor in four SIMD lanes, a coarse
/// row's Galerkin terms).
pub const HEAVY_MIN: usize = 512;

/// `Σ f(chunk)` over the chunks of `0..n`, partials added in order.
pub fn sum(n: usize, f: impl Fn(Range<usize>) -> Real + Sync) -> Real {
    let chunks = n.div_ceil(CHUNK);
    let range = |c: usize| c * CHUNK..((c + 1) * CHUNK).min(n);
    if !is_parallel(n) {
        return (0..chunks).map(|c| f(range(c))).sum();
    }
    let partials: Vec<Real> = (0..chunks).into_par_iter().map(|c| f(range(c))).collect();
    partials.into_iter().sum()
}

/// `aᵀ b`.
pub fn dot(a: &[Vec3], b: &[Vec3]) -> Real {
    sum(a.len(), |r| {
        a[r.clone()].iter().zip(&b[r]).map(|(x, y)| x.dot(y)).sum()
    })
}

/// Runs `f(start, chunk)` on every chunk of `out` (`start`: the chunk's
/// first index).
pub fn for_chunks<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) + Sync) {
    if !is_parallel(out.len()) {
        for (c, chunk) in out.chunks_mut(CHUNK).enumerate() {
            f(c * CHUNK, chunk);
        }
    } else {
        out.par_chunks_mut(CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| f(c * CHUNK, chunk));
    }
}

/// Runs `f(start, a_chunk, b_chunk)` on matching chunks of two slices of
/// the same length.
pub fn for_chunks2<A: Send, B: Send>(
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(usize, &mut [A], &mut [B]) + Sync,
) {
    if !is_parallel(a.len()) {
        for (c, (x, y)) in a.chunks_mut(CHUNK).zip(b.chunks_mut(CHUNK)).enumerate() {
            f(c * CHUNK, x, y);
        }
    } else {
        a.par_chunks_mut(CHUNK)
            .zip(b.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (x, y))| f(c * CHUNK, x, y));
    }
}

/// Runs `f(row, values)` on every row of `out`, a table of rows of
/// `width` values each, spread over threads from `min` values (the
/// caller knows what a value costs: [`HEAVY_MIN`] for a microsecond).
pub fn for_rows<T: Send>(
    out: &mut [T],
    width: usize,
    min: usize,
    f: impl Fn(usize, &mut [T]) + Sync,
) {
    let width = width.max(1);
    let rows_per_chunk = (CHUNK / width).max(1);
    let run = |c: usize, chunk: &mut [T]| {
        for (k, row) in chunk.chunks_mut(width).enumerate() {
            f(c * rows_per_chunk + k, row);
        }
    };
    if !spread(out.len(), min) {
        for (c, chunk) in out.chunks_mut(rows_per_chunk * width).enumerate() {
            run(c, chunk);
        }
    } else {
        out.par_chunks_mut(rows_per_chunk * width)
            .enumerate()
            .for_each(|(c, chunk)| run(c, chunk));
    }
}

/// Runs `a` and `b`, side by side when the pool has threads to spare:
/// for two stages of a step that read nothing the other writes, each
/// sequential inside, so their results do not depend on it.
pub fn join<A: Send, B: Send>(
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    if rayon::current_num_threads() > 1 {
        rayon::join(a, b)
    } else {
        (a(), b())
    }
}

/// Whether work on `n` elements is spread over threads.
pub fn is_parallel(n: usize) -> bool {
    spread(n, PARALLEL_MIN)
}

fn spread(n: usize, min: usize) -> bool {
    n >= min && rayon::current_num_threads() > 1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same sums and loops in a pool of one thread and of four.
    #[test]
    fn results_do_not_depend_on_the_thread_count() {
        let n = 3 * PARALLEL_MIN + 17;
        let a: Vec<Vec3> = (0..n)
            .map(|k| {
                Vec3::new(
                    (k as f64).sin(),
                    1.0 / (1.0 + k as f64),
                    (k % 7) as f64 * 1e-9,
                )
            })
            .collect();
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| {
                let d = dot(&a, &a);
                let mut out = vec![0.0; n];
                for_chunks(&mut out, |start, c| {
                    for (k, o) in c.iter_mut().enumerate() {
                        *o = a[start + k].x * 2.0;
                    }
                });
                (d, out)
            })
        };
        let (d1, o1) = run(1);
        let (d4, o4) = run(4);
        assert_eq!(d1.to_bits(), d4.to_bits());
        assert_eq!(o1, o4);
    }
}
