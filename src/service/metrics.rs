//! Prometheus metrics (`GET /metrics`), through `prometheus-client`.
//!
//! Per node: every series carries this node's name as the label `node`,
//! and the counters, the step-time histogram and `workers_busy` count what
//! happened on this node. Jobs by status and the queue depth are read from
//! the store when scraped, so they are the whole store's (the same on every
//! node sharing it) and right after a restart too.

use std::borrow::Cow;

use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;

use super::job::Status;

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
struct StatusLabel {
    status: &'static str,
}

/// The service's metrics.
#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    jobs: Family<StatusLabel, Gauge>,
    queue_depth: Gauge,
    workers: Gauge,
    workers_busy: Gauge,
    /// Jobs accepted by `POST /v1/jobs`.
    pub submitted: Counter,
    /// Submissions refused because the queue was full.
    pub rejected_queue_full: Counter,
    /// Submissions refused as beyond a per-job budget.
    pub rejected_over_budget: Counter,
    /// Ended jobs deleted (by their owner or by `--retention`).
    pub deleted: Counter,
    /// Frames stored.
    pub frames: Counter,
    /// Wall time of one solver step (a frame's step time over its steps).
    pub step_seconds: Histogram,
}

impl Metrics {
    /// The metrics of node `node`.
    pub fn new(node: &str) -> Self {
        let labels = [(Cow::Borrowed("node"), Cow::Owned(node.to_owned()))];
        let mut registry = Registry::with_prefix_and_labels("drapery", labels.into_iter());
        let jobs = Family::<StatusLabel, Gauge>::default();
        let queue_depth = Gauge::default();
        let workers = Gauge::default();
        let workers_busy = Gauge::default();
        let submitted = Counter::default();
        let rejected_queue_full = Counter::default();
        let rejected_over_budget = Counter::default();
        let deleted = Counter::default();
        let frames = Counter::default();
        // 10 µs .. ~40 s: a 10x10 cloth's step up to a huge one's.
        let step_seconds = Histogram::new(exponential_buckets(1e-5, 2.5, 17));
        registry.register("jobs", "Jobs in the store by status", jobs.clone());
        registry.register(
            "queue_depth",
            "Jobs waiting for a worker",
            queue_depth.clone(),
        );
        registry.register(
            "workers",
            "Worker threads of this node (0: API only)",
            workers.clone(),
        );
        registry.register(
            "workers_busy",
            "Workers running a job",
            workers_busy.clone(),
        );
        registry.register("jobs_submitted", "Jobs accepted", submitted.clone());
        registry.register(
            "jobs_rejected_queue_full",
            "Submissions refused with 429",
            rejected_queue_full.clone(),
        );
        registry.register(
            "jobs_rejected_over_budget",
            "Submissions refused with 422 over_budget",
            rejected_over_budget.clone(),
        );
        registry.register("jobs_deleted", "Ended jobs deleted", deleted.clone());
        registry.register("frames", "Frames stored", frames.clone());
        registry.register(
            "step_seconds",
            "Wall time of one solver step",
            step_seconds.clone(),
        );
        Self {
            registry,
            jobs,
            queue_depth,
            workers,
            workers_busy,
            submitted,
            rejected_queue_full,
            rejected_over_budget,
            deleted,
            frames,
            step_seconds,
        }
    }

    /// The text exposition, with the scrape-time gauges set first.
    pub fn render(
        &self,
        by_status: &[(Status, u64)],
        queue: usize,
        busy: usize,
        workers: usize,
    ) -> String {
        for s in Status::ALL {
            let n = by_status
                .iter()
                .find(|(t, _)| *t == s)
                .map_or(0, |(_, n)| *n);
            self.jobs
                .get_or_create(&StatusLabel { status: s.as_str() })
                .set(n as i64);
        }
        self.queue_depth.set(queue as i64);
        self.workers_busy.set(busy as i64);
        self.workers.set(workers as i64);
        let mut out = String::new();
        // Writing to a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposition_has_every_status_and_the_histogram() {
        let m = Metrics::new("n1");
        m.frames.inc_by(3);
        m.step_seconds.observe(0.002);
        let text = m.render(&[(Status::Succeeded, 2)], 1, 0, 2);
        assert!(
            text.contains("drapery_jobs{node=\"n1\",status=\"succeeded\"} 2"),
            "{text}"
        );
        assert!(
            text.contains("drapery_jobs{node=\"n1\",status=\"queued\"} 0"),
            "{text}"
        );
        assert!(
            text.contains("drapery_queue_depth{node=\"n1\"} 1"),
            "{text}"
        );
        assert!(text.contains("drapery_workers{node=\"n1\"} 2"), "{text}");
        assert!(
            text.contains("drapery_frames_total{node=\"n1\"} 3"),
            "{text}"
        );
        assert!(
            text.contains("drapery_step_seconds_count{node=\"n1\"} 1"),
            "{text}"
        );
    }
}
