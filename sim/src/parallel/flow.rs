//! Stages of tasks on the team without a barrier between stages: each
//! task starts as soon as the tasks it reads from are done.
//!
//! A coloured line sweep is seven stages of a few microseconds each
//! (`solver::lines`). Run as seven loops, every stage ends at a barrier
//! where one core waits for the other's last pack, and both then pay the
//! hand-over of the next loop: the sweep took 31 µs on two threads
//! against 40 µs on one. But a pack of the next colour reads only the
//! lines beside its own, so it may start once the packs holding those
//! lines are done, while the other core finishes elsewhere.
//!
//! How: a thread claims the stages' tasks stage by stage, the caller from
//! each stage's front and helpers from its back (as [`Team::run`] claims,
//! so each core keeps its rows from stage to stage), and moves on to stage
//! `k + 1` only once stage `k` has no unclaimed task. Before running a
//! task it waits for the tasks `needs` names, which must be of earlier
//! stages. No deadlock: a task waits only for tasks of earlier stages,
//! each claimed by a thread that is running it, and the earliest task
//! running has nothing left to wait for.
//!
//! Which thread runs a task changes nothing: the result is the serial
//! one (stages in order, tasks in order) bit for bit, provided `needs`
//! names every task whose output a task reads and every task that reads
//! what it overwrites.
//!
//! [`Team::run`]: super::Team::run

use super::team::{Team, claim_from};
use std::ops::Range;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Mutex;
use std::sync::atomic::Ordering::{Acquire, Relaxed, Release};
use std::sync::atomic::{AtomicU32, AtomicU64};

/// The state of a run of stages, kept between runs so that a run
/// allocates nothing.
#[derive(Debug, Default)]
pub struct Flow {
    /// Per task (stages one after another): the run that finished it.
    done: Vec<AtomicU32>,
    /// Per stage: `end << 32 | next`, its unclaimed tasks.
    claims: Vec<AtomicU64>,
    /// Per stage: its first task's place in `done`.
    starts: Vec<usize>,
    /// This run's number (never 0, which marks a task never run).
    run: u32,
}

impl Clone for Flow {
    /// A fresh state: it holds nothing between runs but buffers.
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl Flow {
    /// Runs `task(k, i)` for each task `i` of each stage `k`
    /// (`stages[k]` tasks), stages in order, each task once `needs(k, i,
    /// wait)` has called `wait(j, range)` for every range of tasks of an
    /// earlier stage `j < k` it depends on. Spread over the team from
    /// `min` tasks in all; below that, or with no helper, stage after
    /// stage on this thread. A task's panic is raised here once every
    /// task has run. (`super::in_stages` runs it on the thread's team.)
    pub fn run<N, T>(&mut self, team: &Team, stages: &[usize], min: usize, needs: N, task: T)
    where
        N: Fn(usize, usize, &mut dyn FnMut(usize, Range<usize>)) + Sync,
        T: Fn(usize, usize) + Sync,
    {
        let total: usize = stages.iter().sum();
        if total < min.max(2) || !team.can_share() {
            for (k, &n) in stages.iter().enumerate() {
                (0..n).for_each(|i| task(k, i));
            }
            return;
        }
        self.prepare(stages);
        let (done, claims, starts, run) = (&self.done, &self.claims, &self.starts, self.run);
        let panic = Mutex::new(None);
        team.run(team.threads(), &|worker| {
            let front = worker == 0;
            for (k, claim) in claims.iter().enumerate() {
                while let Some(i) = claim_from(claim, front) {
                    let waited_then_ran = catch_unwind(AssertUnwindSafe(|| {
                        needs(k, i, &mut |j, range| {
                            assert!(j < k, "stage {k} waits for stage {j}");
                            for t in range {
                                wait(&done[starts[j] + t], run);
                            }
                        });
                        task(k, i);
                    }));
                    if let Err(p) = waited_then_ran {
                        *panic.lock().unwrap_or_else(|p| p.into_inner()) = Some(p);
                    }
                    // Done even after a panic, so no one waits forever.
                    done[starts[k] + i].store(run, Release);
                }
            }
        });
        if let Some(p) = panic.into_inner().unwrap_or_else(|p| p.into_inner()) {
            resume_unwind(p);
        }
    }

    /// A new run's number, stages' places and claims. Every run marks
    /// every task, so at a run's start no flag holds its number.
    fn prepare(&mut self, stages: &[usize]) {
        self.run = self.run.wrapping_add(1).max(1);
        self.starts.clear();
        let mut at = 0;
        for &n in stages {
            self.starts.push(at);
            at += n;
        }
        assert!(at < 1 << 32, "a flow of {at} tasks");
        if self.done.len() != at {
            self.done = (0..at).map(|_| AtomicU32::new(0)).collect();
        }
        self.claims.resize_with(stages.len(), || AtomicU64::new(0));
        for (claim, &n) in self.claims.iter().zip(stages) {
            // Published to the helpers by the team's job (`Team::run`).
            claim.store((n as u64) << 32, Relaxed);
        }
    }
}

/// Spins until `flag` says run `run` finished its task, then yields
/// between polls (its owner may have lost its core).
fn wait(flag: &AtomicU32, run: u32) {
    let mut polls = 0u32;
    while flag.load(Acquire) != run {
        polls = polls.saturating_add(1);
        if polls < 1 << 10 {
            std::hint::spin_loop();
        } else {
            std::thread::yield_now();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Disjoint, in_stages, with_threads};
    use super::*;

    /// Red–black Gauss–Seidel on a 1-D chain: stage `k` relaxes colour
    /// `k % 2` in chunks of four nodes, each reading the other colour's
    /// neighbours, which the previous stage's chunks `i - 1 ..= i + 1`
    /// wrote. Run as a flow on teams of one to three threads, many
    /// times, it gives the serial sweep's numbers bit for bit.
    #[test]
    fn a_flow_gives_the_serial_result_on_any_team() {
        const NODES: usize = 2 * 4 * 9;
        const STAGES: usize = 9;
        let chunks = NODES / 2 / 4;
        let sweep = |flow: &mut Flow| {
            let mut x: Vec<f64> = (0..NODES).map(|k| (k as f64 * 0.37).sin()).collect();
            let shared = Disjoint::new(&mut x);
            let stages = [chunks; STAGES];
            in_stages(
                flow,
                &stages,
                0,
                |k, i, wait| {
                    if k > 0 {
                        wait(k - 1, i.saturating_sub(1)..(i + 2).min(chunks));
                    }
                },
                |k, i| {
                    for m in 4 * i..4 * i + 4 {
                        let p = 2 * m + k % 2;
                        // SAFETY: node `p` is of this stage's colour and
                        // this chunk's alone; its neighbours are of the
                        // other colour, written by the previous stage's
                        // chunks this task waited for.
                        #[allow(unsafe_code)]
                        unsafe {
                            let left = if p > 0 { shared.read(p - 1) } else { 0.0 };
                            let right = if p + 1 < NODES {
                                shared.read(p + 1)
                            } else {
                                0.0
                            };
                            shared.write(p, (1.0 + left + right) / 2.0 + 1e-3 * k as f64);
                        }
                    }
                },
            );
            x
        };
        let serial = with_threads(1, || sweep(&mut Flow::default()));
        for threads in [2, 3] {
            with_threads(threads, || {
                let mut flow = Flow::default();
                for _ in 0..300 {
                    let x = sweep(&mut flow);
                    assert!(
                        x.iter()
                            .zip(&serial)
                            .all(|(a, b)| a.to_bits() == b.to_bits())
                    );
                }
            });
        }
    }

    /// A task's panic reaches the caller once every other task has run,
    /// and the tasks waiting for the one that panicked do not hang.
    #[test]
    fn a_panic_reaches_the_caller_and_no_one_waits_forever() {
        with_threads(2, || {
            let mut flow = Flow::default();
            for _ in 0..20 {
                let ran = std::sync::atomic::AtomicUsize::new(0);
                let caught = catch_unwind(AssertUnwindSafe(|| {
                    in_stages(
                        &mut flow,
                        &[4, 4, 4],
                        0,
                        |k, _, wait| {
                            if k > 0 {
                                wait(k - 1, 0..4);
                            }
                        },
                        |k, i| {
                            if (k, i) == (0, 2) {
                                panic!("task (0, 2)");
                            }
                            ran.fetch_add(1, Relaxed);
                        },
                    );
                }));
                assert!(caught.is_err());
                assert_eq!(ran.load(Relaxed), 11);
            }
        });
    }
}
