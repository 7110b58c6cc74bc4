//! Deterministic parallel loops: results bit for bit independent of the
//! number of threads, so a checkpoint resumes exactly on any machine.
//!
//! Loops that write each element from its own inputs ([`for_chunks`],
//! [`for_rows`]) may be cut anywhere: they are cut into a few pieces per
//! thread, which the team's threads claim as they come free. A sum
//! ([`sum`], [`dot`]) is cut into chunks of a fixed size ([`CHUNK`]),
//! never into one piece per thread, and adds each chunk's partial in
//! chunk order, so which thread ran a chunk changes nothing. Loops
//! shorter than their threshold ([`PARALLEL_MIN`], or the caller's for
//! heavier elements) run on the calling thread, with the same chunks and
//! the same sums.
//!
//! The threads are a [`Team`] of the process (sized once at start:
//! `drapery --threads`, `DRAPERY_THREADS`; default every core), or one of
//! a caller's own ([`with_threads`]). A loop started inside another
//! loop's task, or while another job (in the service) has the team, runs
//! on its own thread; so do a run's loops while its [`Tuner`] measured
//! them faster alone. Stages of tasks that wait only for their
//! neighbours in earlier stages run as one [`Flow`] ([`in_stages`]),
//! without a barrier between stages.

mod disjoint;
mod flow;
mod team;
mod tuner;

use std::cell::RefCell;
use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

pub use disjoint::Disjoint;
pub use flow::Flow;
pub use team::Team;
pub use tuner::Tuner;

use crate::math::{Real, Vec3};

/// Elements per chunk of a sum.
pub const CHUNK: usize = 512;
/// Fewest elements worth spreading over threads for loops of a few
/// nanoseconds per element (vector updates, sums): below it, a loop is
/// shorter than what sharing it costs (~0.3 µs with the team spinning,
/// plus the cache lines that change hands).
pub const PARALLEL_MIN: usize = 4096;
/// Fewest elements worth spreading when each is tens of nanoseconds of
/// work (a block row of the sparse product, a line's node).
pub const ROWS_MIN: usize = 256;
/// Fewest values of a [`for_rows`] table worth spreading when each is
/// a microsecond of work (a node's factor in four SIMD lanes, a coarse
/// row's Galerkin terms).
pub const HEAVY_MIN: usize = 64;
/// Pieces a loop is cut into per thread: more than one, so a thread that
/// was slow to start (or preempted) leaves its share to the others.
const PIECES_PER_THREAD: usize = 4;
/// Most pieces of one loop.
const MAX_PIECES: usize = 32;

static GLOBAL: OnceLock<Team> = OnceLock::new();

thread_local! {
    /// The team of [`with_threads`], while it runs.
    static CURRENT: RefCell<Option<Arc<Team>>> = const { RefCell::new(None) };
}

/// Sizes the process's team to `threads` threads; call once, before any
/// loop runs. `Err` with the size in use if it was already set.
pub fn init(threads: usize) -> Result<(), usize> {
    let mut fresh = false;
    let team = GLOBAL.get_or_init(|| {
        fresh = true;
        Team::new(threads)
    });
    if fresh || team.threads() == threads {
        Ok(())
    } else {
        Err(team.threads())
    }
}

/// Runs `f` with a team of `threads` threads of its own for the loops it
/// starts on this thread (a benchmark's thread counts, tests).
pub fn with_threads<R>(threads: usize, f: impl FnOnce() -> R) -> R {
    let team = Arc::new(Team::new(threads));
    let previous = CURRENT.replace(Some(team));
    struct Restore(Option<Arc<Team>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            CURRENT.set(self.0.take());
        }
    }
    let _restore = Restore(previous);
    f()
}

/// Calls `f` with the team loops started on this thread use.
fn with_team<R>(f: impl FnOnce(&Team) -> R) -> R {
    CURRENT.with_borrow(|current| match current {
        Some(team) => f(team),
        None => f(GLOBAL.get_or_init(|| {
            Team::new(std::thread::available_parallelism().map_or(1, |n| n.get()))
        })),
    })
}

/// Threads of the team loops started on this thread use.
pub fn threads() -> usize {
    with_team(|t| t.threads())
}

/// Whether a loop started on this thread now would be shared (helpers,
/// not inside a task, not set alone by the [`Tuner`]): for a caller whose
/// way of cutting work costs something only worth paying when shared.
pub fn sharing() -> bool {
    with_team(|t| t.threads() > 1 && t.can_share())
}

/// Takes what `m` holds, poisoned or not.
fn take<T>(m: &Mutex<Option<T>>) -> Option<T> {
    m.lock().unwrap_or_else(|p| p.into_inner()).take()
}

/// Runs `f` on every item, spread over the team's threads (at most
/// [`MAX_PIECES`] at once): items of a few microseconds or more each.
pub fn each<P: Send>(items: impl IntoIterator<Item = P>, f: impl Fn(P) + Sync) {
    with_team(|team| {
        let mut items = items.into_iter().peekable();
        while items.peek().is_some() {
            let mut cells: [Mutex<Option<P>>; MAX_PIECES] =
                std::array::from_fn(|_| Mutex::new(None));
            let mut count = 0;
            for (cell, item) in cells.iter_mut().zip(items.by_ref()) {
                *cell.get_mut().unwrap_or_else(|p| p.into_inner()) = Some(item);
                count += 1;
            }
            team.run(count, &|i| {
                if let Some(item) = take(&cells[i]) {
                    f(item);
                }
            });
        }
    });
}

/// [`Flow::run`] on the team loops started on this thread use: stages of
/// tasks, each task run once the tasks of earlier stages it needs are.
pub fn in_stages<N, T>(flow: &mut Flow, stages: &[usize], min: usize, needs: N, task: T)
where
    N: Fn(usize, usize, &mut dyn FnMut(usize, Range<usize>)) + Sync,
    T: Fn(usize, usize) + Sync,
{
    with_team(|team| flow.run(team, stages, min, needs, task));
}

/// Elements per piece when `n` elements are spread (`None`: not spread),
/// pieces no smaller than `min / 2`.
fn piece_len(n: usize, min: usize) -> Option<usize> {
    with_team(|team| {
        if n < min.max(2) || !team.can_share() {
            return None;
        }
        let pieces = (team.threads() * PIECES_PER_THREAD)
            .min(MAX_PIECES)
            .min(2 * n / min.max(1))
            .max(2);
        Some(n.div_ceil(pieces))
    })
}

/// `Σ f(chunk)` over the chunks of `0..n`, partials added in order (from
/// `-0.0`, as `Iterator::sum` starts).
pub fn sum(n: usize, f: impl Fn(Range<usize>) -> Real + Sync) -> Real {
    sum_of(n, -0.0, f)
}

/// [`sum`] of values of any type that adds (a vector, a matrix): the same
/// fixed chunks, partials added in chunk order from `zero`.
pub fn sum_of<T>(n: usize, zero: T, f: impl Fn(Range<usize>) -> T + Sync) -> T
where
    T: Copy + Send + std::ops::Add<Output = T>,
{
    let chunks = n.div_ceil(CHUNK);
    let range = |c: usize| c * CHUNK..((c + 1) * CHUNK).min(n);
    if piece_len(n, PARALLEL_MIN).is_none() {
        return (0..chunks).map(|c| f(range(c))).fold(zero, |a, b| a + b);
    }
    let mut partials = vec![zero; chunks];
    for_rows(&mut partials, 1, 2, |c, p| p[0] = f(range(c)));
    partials.into_iter().fold(zero, |a, b| a + b)
}

/// `Σ f(start, chunk)` over the chunks of `out` that [`sum`] would cut,
/// partials added in order, where `f` may also write its chunk: an update
/// and a sum of it in one pass, bit for bit the two passes' results.
pub fn update_sum<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) -> Real + Sync) -> Real {
    if piece_len(out.len(), PARALLEL_MIN).is_none() {
        return out
            .chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, chunk)| f(c * CHUNK, chunk))
            .sum();
    }
    let mut partials = vec![0.0; out.len().div_ceil(CHUNK)];
    each(
        out.chunks_mut(CHUNK).zip(&mut partials).enumerate(),
        |(c, (chunk, p)): (usize, (&mut [T], &mut Real))| *p = f(c * CHUNK, chunk),
    );
    partials.into_iter().sum()
}

/// [`update_sum`] over two slices of the same length, cut into the same
/// chunks: `f(start, a_chunk, b_chunk)` may write both and returns its
/// chunk's share of the sum (two updates and a sum in one pass, bit for
/// bit the separate passes' results).
pub fn update_sum2<A: Send, B: Send>(
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(usize, &mut [A], &mut [B]) -> Real + Sync,
) -> Real {
    assert_eq!(a.len(), b.len(), "update_sum2 over slices of two lengths");
    if piece_len(a.len(), PARALLEL_MIN).is_none() {
        return a
            .chunks_mut(CHUNK)
            .zip(b.chunks_mut(CHUNK))
            .enumerate()
            .map(|(c, (x, y))| f(c * CHUNK, x, y))
            .sum();
    }
    // A chunk of each slice and its partial sum.
    type Piece<'p, A, B> = ((&'p mut [A], &'p mut [B]), &'p mut Real);
    let mut partials = vec![0.0; a.len().div_ceil(CHUNK)];
    each(
        a.chunks_mut(CHUNK)
            .zip(b.chunks_mut(CHUNK))
            .zip(&mut partials)
            .enumerate(),
        |(c, ((x, y), p)): (usize, Piece<'_, A, B>)| *p = f(c * CHUNK, x, y),
    );
    partials.into_iter().sum()
}

/// `aᵀ b`.
pub fn dot(a: &[Vec3], b: &[Vec3]) -> Real {
    sum(a.len(), |r| {
        a[r.clone()].iter().zip(&b[r]).map(|(x, y)| x.dot(y)).sum()
    })
}

/// Runs `f(start, piece)` on pieces of `out` that cover it (`start`: the
/// piece's first index); `f` must compute each element on its own, since
/// where the pieces are cut depends on the thread count. For elements of
/// a few nanoseconds ([`PARALLEL_MIN`]).
pub fn for_chunks<T: Send>(out: &mut [T], f: impl Fn(usize, &mut [T]) + Sync) {
    for_chunks_min(out, PARALLEL_MIN, f);
}

/// [`for_chunks`], spread from `min` elements.
pub fn for_chunks_min<T: Send>(out: &mut [T], min: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    match piece_len(out.len(), min) {
        None => f(0, out),
        Some(len) => each(
            out.chunks_mut(len).enumerate(),
            |(k, piece): (usize, &mut [T])| f(k * len, piece),
        ),
    }
}

/// Runs `f(start, a_piece, b_piece)` on matching pieces of two slices of
/// the same length, as [`for_chunks`].
pub fn for_chunks2<A: Send, B: Send>(
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(usize, &mut [A], &mut [B]) + Sync,
) {
    match piece_len(a.len(), PARALLEL_MIN) {
        None => f(0, a, b),
        Some(len) => each(
            a.chunks_mut(len).zip(b.chunks_mut(len)).enumerate(),
            |(k, (x, y)): (usize, (&mut [A], &mut [B]))| f(k * len, x, y),
        ),
    }
}

/// Runs `f(row, values)` on every row of `out`, a table of rows of
/// `width` values each, spread over threads from `min` values (the
/// caller knows what a value costs: [`ROWS_MIN`], [`HEAVY_MIN`]).
pub fn for_rows<T: Send>(
    out: &mut [T],
    width: usize,
    min: usize,
    f: impl Fn(usize, &mut [T]) + Sync,
) {
    let width = width.max(1);
    let rows = out.len() / width;
    let run = |first: usize, piece: &mut [T]| {
        for (k, row) in piece.chunks_mut(width).enumerate() {
            f(first + k, row);
        }
    };
    // Pieces of whole rows, at least one row each.
    match piece_len(out.len(), min).map(|len| len.div_ceil(width).min(rows.max(1))) {
        None => run(0, out),
        Some(per) => each(
            out.chunks_mut(per * width).enumerate(),
            |(k, piece): (usize, &mut [T])| run(k * per, piece),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same sums and loops on teams of one thread and of four.
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
            with_threads(threads, || {
                let d = dot(&a, &a);
                let mut out = vec![0.0; n];
                for_chunks(&mut out, |start, c| {
                    for (k, o) in c.iter_mut().enumerate() {
                        *o = a[start + k].x * 2.0;
                    }
                });
                let mut rows = vec![0.0; 3 * 301];
                for_rows(&mut rows, 3, 2, |r, row| {
                    row.iter_mut()
                        .enumerate()
                        .for_each(|(k, v)| *v = (r * 3 + k) as f64);
                });
                // An update fused with its sum: the two passes' numbers.
                let mut scaled = a.clone();
                let fused = update_sum(&mut scaled, |start, c| {
                    c.iter_mut()
                        .enumerate()
                        .map(|(k, v)| {
                            *v *= 1.5;
                            a[start + k].dot(v)
                        })
                        .sum()
                });
                let twice: Vec<Vec3> = a.iter().map(|v| v * 1.5).collect();
                assert_eq!(scaled, twice);
                assert_eq!(fused.to_bits(), dot(&a, &twice).to_bits());
                // Two updates fused with the sum of one.
                let (mut left, mut right) = (a.clone(), a.clone());
                let fused2 = update_sum2(&mut left, &mut right, |start, l, r| {
                    l.iter_mut()
                        .zip(r.iter_mut())
                        .enumerate()
                        .map(|(k, (l, r))| {
                            *l *= 1.5;
                            *r -= a[start + k] * 0.5;
                            r.dot(r)
                        })
                        .sum()
                });
                let half: Vec<Vec3> = a.iter().map(|v| v - v * 0.5).collect();
                assert_eq!((&left, &right), (&twice, &half));
                assert_eq!(fused2.to_bits(), dot(&half, &half).to_bits());
                (d, out, rows)
            })
        };
        let (d1, o1, r1) = run(1);
        let (d4, o4, r4) = run(4);
        assert_eq!(d1.to_bits(), d4.to_bits());
        assert_eq!(o1, o4);
        assert_eq!(r1, r4);
        assert!(r1.iter().enumerate().all(|(k, &v)| v == k as f64));
    }
}
