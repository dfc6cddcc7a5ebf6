//! A bounded inbox that keeps each key's latest input: a robot's telemetry sample supersedes the
//! one of that robot still waiting, so a node that falls behind handles every robot's freshest
//! sample in turn instead of a backlog of old ones, or none of some robots'.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use tokio::sync::Notify;

/// The sending side (clonable) of a latest-per-key inbox.
#[derive(Debug)]
pub struct Latest<T> {
    inner: Arc<Inner<T>>,
}

impl<T> Clone for Latest<T> {
    fn clone(&self) -> Self {
        Latest { inner: self.inner.clone() }
    }
}

/// The receiving side.
#[derive(Debug)]
pub struct LatestRx<T> {
    inner: Arc<Inner<T>>,
}

#[derive(Debug)]
struct Inner<T> {
    what: &'static str,
    /// Keys waiting at most.
    capacity: usize,
    waiting: Mutex<Waiting<T>>,
    arrived: Notify,
    /// New keys refused because `capacity` keys were waiting.
    dropped: AtomicU64,
    /// Inputs replaced by a newer one of their key before they were taken.
    superseded: AtomicU64,
}

#[derive(Debug)]
struct Waiting<T> {
    by_key: HashMap<String, T>,
    /// Keys in the order they first arrived (each at most once).
    order: VecDeque<String>,
}

impl<T> Latest<T> {
    /// An inbox of at most `capacity` keys' inputs of `what`.
    pub fn new(what: &'static str, capacity: usize) -> (Latest<T>, LatestRx<T>) {
        let waiting = Waiting { by_key: HashMap::new(), order: VecDeque::new() };
        let inner = Arc::new(Inner {
            what,
            capacity: capacity.max(1),
            waiting: Mutex::new(waiting),
            arrived: Notify::new(),
            dropped: AtomicU64::new(0),
            superseded: AtomicU64::new(0),
        });
        (Latest { inner: inner.clone() }, LatestRx { inner })
    }

    /// Queues `v` as `key`'s latest; never blocks. Replaces what `key` had waiting (counted); a
    /// new key when `capacity` keys are waiting is dropped (counted, logged at powers of two).
    pub fn push(&self, key: &str, v: T) {
        let inner = &self.inner;
        {
            let Ok(mut w) = inner.waiting.lock() else { return };
            if let Some(slot) = w.by_key.get_mut(key) {
                *slot = v;
                inner.superseded.fetch_add(1, Ordering::Relaxed);
                return;
            }
            if w.by_key.len() >= inner.capacity {
                let n = inner.dropped.fetch_add(1, Ordering::Relaxed) + 1;
                if n.is_power_of_two() {
                    tracing::warn!(what = inner.what, dropped = n, key, "input queue full: dropping input (the node is overloaded or flooded)");
                }
                return;
            }
            w.by_key.insert(key.to_string(), v);
            w.order.push_back(key.to_string());
        }
        inner.arrived.notify_one();
    }

    /// Inputs dropped so far (new keys beyond the capacity).
    pub fn dropped(&self) -> u64 {
        self.inner.dropped.load(Ordering::Relaxed)
    }

    /// Inputs replaced by a newer one of their key so far.
    pub fn superseded(&self) -> u64 {
        self.inner.superseded.load(Ordering::Relaxed)
    }
}

impl<T> LatestRx<T> {
    /// The input of the key that has waited longest. Cancel-safe: an input is taken only by the
    /// poll that returns it.
    pub async fn recv(&mut self) -> T {
        loop {
            if let Some(v) = self.take() {
                return v;
            }
            self.inner.arrived.notified().await;
        }
    }

    fn take(&self) -> Option<T> {
        let mut w = self.inner.waiting.lock().ok()?;
        while let Some(key) = w.order.pop_front() {
            if let Some(v) = w.by_key.remove(&key) {
                return Some(v);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn each_key_keeps_its_latest_in_the_order_keys_came() {
        let (tx, mut rx) = Latest::new("test", 8);
        tx.push("r1", 1);
        tx.push("r2", 10);
        tx.push("r1", 2);
        tx.push("r1", 3);
        assert_eq!(tx.superseded(), 2);
        assert_eq!((rx.recv().await, rx.recv().await), (3, 10));
        tx.push("r1", 4);
        assert_eq!(rx.recv().await, 4, "a key taken waits anew");
    }

    #[tokio::test]
    async fn a_flood_of_one_key_holds_one_slot_and_new_keys_beyond_the_capacity_are_dropped() {
        let (tx, mut rx) = Latest::new("test", 2);
        for i in 0..10_000 {
            tx.push("r1", i);
        }
        tx.push("r2", -1);
        tx.push("r3", -2);
        assert_eq!((tx.dropped(), tx.superseded()), (1, 9_999));
        assert_eq!((rx.recv().await, rx.recv().await), (9_999, -1));
    }

    #[tokio::test]
    async fn a_waiting_receiver_wakes_when_input_arrives() {
        let (tx, mut rx) = Latest::new("test", 2);
        let waiter = tokio::spawn(async move { rx.recv().await });
        tokio::task::yield_now().await;
        tx.push("r1", 7);
        let got = tokio::time::timeout(std::time::Duration::from_secs(5), waiter).await.expect("woke").expect("joined");
        assert_eq!(got, 7);
    }
}
