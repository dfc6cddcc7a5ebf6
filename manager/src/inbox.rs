//! Bounded queues from Zenoh callbacks to a node's loop. A callback runs on Zenoh's receiving
//! thread and must never block it; a remote must not be able to grow a node's memory by sending
//! faster than the loop handles. So input goes through an [`Inbox`]: when the loop falls behind,
//! new input is dropped, counted and logged (rate-limited); the senders' own retries (plans,
//! controls, re-published arrivals, periodic telemetry) make up for it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use tokio::sync::mpsc;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Session;

use crate::error::ManagerError;

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
            let n = self.dropped.fetch_add(1, Ordering::Relaxed) + 1;
            if n.is_power_of_two() {
                tracing::warn!(what = self.what, dropped = n, "input queue full: dropping input (the node is overloaded or flooded)");
            }
        }
    }

    /// Items dropped so far.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }
}

impl<T: Send + 'static> Inbox<T> {
    /// Subscribes to `key`: each sample is queued as `wrap(sample)`.
    pub async fn subscribe(&self, session: &Session, key: String, wrap: fn(Sample) -> T) -> Result<Subscriber<()>, ManagerError> {
        let t = self.clone();
        session.declare_subscriber(key).callback(move |s| t.push(wrap(s))).await.map_err(ManagerError::zenoh)
    }

    /// Follows the liveliness tokens on `key`, those alive already included: each appearance and
    /// disappearance is queued as `wrap(sample)`.
    pub async fn liveliness(&self, session: &Session, key: String, wrap: fn(Sample) -> T) -> Result<Subscriber<()>, ManagerError> {
        let t = self.clone();
        session.liveliness().declare_subscriber(key).history(true).callback(move |s| t.push(wrap(s))).await.map_err(ManagerError::zenoh)
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
}
