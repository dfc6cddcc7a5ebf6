//! What a node's seal checks refused and took, counted: refusals by kind (logged, rate-limited),
//! messages taken by how their sender was proven.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use super::Refusal;

/// Counters of refused messages, by kind.
#[derive(Debug, Default)]
pub struct Refused {
    counts: Mutex<std::collections::BTreeMap<&'static str, u64>>,
    logged: AtomicU64,
    window: Mutex<Option<Instant>>,
}

/// Refusals logged at most this many times per 10 s window (the rest are counted).
const LOG_BURST: u64 = 20;

impl Refused {
    /// Counts (and logs, rate-limited; not an unaddressed message) a refusal of `what`.
    pub fn record(&self, what: &str, r: &Refusal) {
        if let Ok(mut c) = self.counts.lock() {
            let n = c.entry(r.kind()).or_insert(0);
            *n = n.saturating_add(1);
        }
        // Messages tagged for other receivers are an everyday sight for a subscriber that is not
        // one, and so are a stream's messages naming a certificate a receiver that just joined
        // has not seen yet (counted only).
        if matches!(r, Refusal::Unaddressed { .. } | Refusal::Unseen { .. }) {
            return;
        }
        let fresh = match self.window.lock() {
            Ok(mut w) => {
                if w.is_none_or(|t| t.elapsed().as_secs() >= 10) {
                    *w = Some(Instant::now());
                    self.logged.store(0, Ordering::Relaxed);
                }
                true
            }
            Err(_) => false,
        };
        if fresh && self.logged.fetch_add(1, Ordering::Relaxed) < LOG_BURST {
            tracing::warn!(kind = r.kind(), "refused {what}: {r}");
        }
    }

    /// Refusals so far, by kind.
    pub fn counts(&self) -> std::collections::BTreeMap<String, u64> {
        self.counts.lock().map(|c| c.iter().map(|(k, v)| (k.to_string(), *v)).collect()).unwrap_or_default()
    }

    pub fn total(&self) -> u64 {
        self.counts.lock().map(|c| c.values().sum()).unwrap_or(0)
    }
}

/// Messages taken, by how their sender was proven.
#[derive(Debug, Default)]
pub struct Proofs {
    pub(super) tag: AtomicU64,
    pub(super) signature: AtomicU64,
}

impl Proofs {
    /// `tag` and `signature` counts.
    pub fn counts(&self) -> std::collections::BTreeMap<String, u64> {
        [("tag", &self.tag), ("signature", &self.signature)].into_iter().map(|(k, v)| (k.to_string(), v.load(Ordering::Relaxed))).collect()
    }
}
