//! Bounded queues from Zenoh callbacks to a node's loop: every node's one discipline (central,
//! the mission hosts, the robots, the traffic deputies). A callback runs on Zenoh's receiving
//! thread and must never block it; a remote must not be able to grow a node's memory by sending
//! faster than the loop handles. So input goes through an [`Inbox`]: when the loop falls behind,
//! new input is dropped, counted and logged (rate-limited); the senders' own retries (plans,
//! controls, re-published arrivals, periodic telemetry) make up for it.
//!
//! A node's loop takes its input by priority ([`Lanes`]): liveliness (a robot's death must not
//! wait behind data), its own tasks' answers, control (chain messages, queries, statuses), then
//! telemetry ([`is_telemetry`]). Telemetry is most of what a node hears and the only input a newer sample
//! replaces, so an overloaded node sheds it first: its inbox keeps each robot's latest sample
//! ([`Latest`]), and a flood of it never drops a chain acknowledgement (a 450-robot mission's
//! head, starved of CPU, once could not commit for 20 s and its mission was started anew).

mod latest;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use tokio::sync::mpsc;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;
use zenoh::Session;

pub use latest::{Latest, LatestRx};
use mrmm_proto::ProtoError;

/// The sending side of a bounded queue.
#[derive(Debug)]
pub struct Inbox<T> {
    what: &'static str,
    tx: mpsc::Sender<T>,
    dropped: Arc<AtomicU64>,
}

impl<T> Clone for Inbox<T> {
    fn clone(&self) -> Self {
        Inbox { what: self.what, tx: self.tx.clone(), dropped: self.dropped.clone() }
    }
}

impl<T> Inbox<T> {
    /// A queue of at most `capacity` items of `what`.
    pub fn new(what: &'static str, capacity: usize) -> (Inbox<T>, mpsc::Receiver<T>) {
        let (tx, rx) = mpsc::channel(capacity.max(1));
        (Inbox { what, tx, dropped: Arc::new(AtomicU64::new(0)) }, rx)
    }

    /// Queues `v`, or drops it (counted) when the queue is full; never blocks.
    pub fn push(&self, v: T) {
        if let Err(mpsc::error::TrySendError::Full(_)) = self.tx.try_send(v) {
            self.count_drop("");
        }
    }

    /// Queues a sample received on `key`, or drops it (counted, the key logged with the count).
    pub fn push_from(&self, key: &str, v: T) {
        if let Err(mpsc::error::TrySendError::Full(_)) = self.tx.try_send(v) {
            self.count_drop(key);
        }
    }

    /// Counts a dropped input; logs the count (and the key it came on) at every power of two.
    fn count_drop(&self, key: &str) {
        let n = self.dropped.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_power_of_two() {
            tracing::warn!(what = self.what, dropped = n, key, "input queue full: dropping input (the node is overloaded or flooded)");
        }
    }

    /// Items dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

/// A queue a sample goes on by the key it came on: an [`Inbox`] (in order) or a [`Latest`] (each
/// key's latest).
pub trait Keyed<T>: Clone + Send + Sync + 'static {
    /// Queues `v`, received on `key`; never blocks.
    fn push_keyed(&self, key: &str, v: T);
}

impl<T: Send + 'static> Keyed<T> for Inbox<T> {
    fn push_keyed(&self, key: &str, v: T) {
        self.push_from(key, v)
    }
}

impl<T: Send + 'static> Keyed<T> for Latest<T> {
    fn push_keyed(&self, key: &str, v: T) {
        self.push(key, v)
    }
}

/// Subscribes to `key`: each sample is queued on `queue` as `wrap(sample)`.
pub async fn subscribe<T: Send + 'static>(queue: &impl Keyed<T>, session: &Session, key: String, wrap: fn(Sample) -> T) -> Result<Subscriber<()>, ProtoError> {
    let q = queue.clone();
    session
        .declare_subscriber(key)
        .callback(move |s| {
            let key = s.key_expr().clone();
            q.push_keyed(key.as_str(), wrap(s))
        })
        .await
        .map_err(ProtoError::zenoh)
}

/// Serves the queryable `key`: each query is queued on `queue` as `wrap(query)`.
pub async fn queryable<T: Send + 'static>(queue: &Inbox<T>, session: &Session, key: String, wrap: fn(Query) -> T) -> Result<Queryable<()>, ProtoError> {
    let q = queue.clone();
    session.declare_queryable(key).callback(move |query| q.push(wrap(query))).await.map_err(ProtoError::zenoh)
}

impl<T: Send + 'static> Inbox<T> {
    /// Follows the liveliness tokens on `key`, those alive already included: each appearance and
    /// disappearance is queued as `wrap(sample)`.
    pub async fn liveliness(&self, session: &Session, key: String, wrap: fn(Sample) -> T) -> Result<Subscriber<()>, ProtoError> {
        let t = self.clone();
        session.liveliness().declare_subscriber(key).history(true).callback(move |s| t.push(wrap(s))).await.map_err(ProtoError::zenoh)
    }
}

/// The receiving ends of a node's inboxes, taken by priority: liveliness, the node's own tasks'
/// answers, control, telemetry.
#[derive(Debug)]
pub struct Lanes<T> {
    pub live: mpsc::Receiver<T>,
    pub own: mpsc::UnboundedReceiver<T>,
    pub control: mpsc::Receiver<T>,
    pub telemetry: LatestRx<T>,
}

impl<T> Lanes<T> {
    /// The next input, of the first lane by priority that has one; `None` once one is closed.
    pub async fn recv(&mut self) -> Option<T> {
        tokio::select! {
            biased;
            i = self.live.recv() => i,
            i = self.own.recv() => i,
            i = self.control.recv() => i,
            i = self.telemetry.recv() => Some(i),
        }
    }
}

/// Whether a sample on `key` is a robot's telemetry (for the telemetry inbox).
pub fn is_telemetry(key: &str) -> bool {
    matches!(mrmm_proto::Key::parse(key), Some(mrmm_proto::Key::RobotTelemetry(_)))
}

/// Puts a sample on the inbox of its kind: telemetry (its robot's latest), or control.
pub fn sort<T>(control: &Inbox<T>, telemetry: &Latest<T>, s: Sample, wrap: fn(Sample) -> T) {
    let key = s.key_expr().clone();
    if is_telemetry(key.as_str()) {
        telemetry.push(key.as_str(), wrap(s));
    } else {
        control.push_from(key.as_str(), wrap(s));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_full_inbox_drops_and_counts_without_blocking() {
        let (inbox, mut rx) = Inbox::new("test", 2);
        for i in 0..5 {
            inbox.push(i);
        }
        assert_eq!(inbox.dropped(), 3);
        assert_eq!((rx.recv().await, rx.recv().await), (Some(0), Some(1)));
    }

    #[tokio::test]
    async fn control_goes_first_and_a_telemetry_flood_costs_it_nothing() {
        let (_live, live) = Inbox::<&str>::new("live", 4);
        let (own_tx, own) = mpsc::unbounded_channel();
        let (control, control_rx) = Inbox::new("control", 4);
        let (telemetry, telemetry_rx) = Latest::new("telemetry", 4);
        let mut lanes = Lanes { live, own, control: control_rx, telemetry: telemetry_rx };
        for i in 0..100 {
            telemetry.push(&format!("r{}", i % 8), "telemetry");
        }
        control.push("chain ack");
        own_tx.send("planned").expect("open");
        assert_eq!((telemetry.dropped(), control.dropped()), (48, 0));
        assert_eq!(lanes.recv().await, Some("planned"));
        assert_eq!(lanes.recv().await, Some("chain ack"));
        assert_eq!(lanes.recv().await, Some("telemetry"));
        control.push("status");
        assert_eq!(lanes.recv().await, Some("status"), "control overtakes telemetry already queued");
    }

    #[test]
    fn telemetry_is_told_from_control_by_its_key() {
        use mrmm_proto::Key;
        assert!(is_telemetry(&Key::RobotTelemetry("r1".into()).to_string()));
        let others =
            [Key::HostChain("r1".into()), Key::MissionStatus("p".into()), Key::RobotInfo("r1".into()), Key::TeamSync { team: "p".into(), point: 0, round: 1 }];
        for key in others.iter().map(Key::to_string).chain(["garbage".to_string()]) {
            assert!(!is_telemetry(&key), "{key}");
        }
    }
}
