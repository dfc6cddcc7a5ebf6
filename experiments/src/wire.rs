//! Messages on the wire, per kind: every node of the experiment's fleet counts what it sends on
//! its links in Zenoh's statistics (`wire_stats`), read from each node's admin space. A
//! publication to k subscribers on other nodes is k messages here — and one more to central:
//! Zenoh 1.10 peers also send a publication to the router they are linked to whenever it has a
//! matching subscriber *or knows of one behind it* (the peers' own subscriptions, which it
//! re-declares), and central drops it. What central receives is kept apart.

use std::collections::BTreeMap;
use std::time::Duration;

use anyhow::anyhow;
use mrmm_net::client::Client;
use mrmm_proto::keys::{wire_stats_selector, WIRE_KINDS};
use zenoh::query::ConsolidationMode;

/// Messages sent per kind (puts, queries and replies), summed over the nodes that answered.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Wire {
    pub nodes: usize,
    pub sent: BTreeMap<String, u64>,
    /// Of those, what central (the router) received.
    pub to_router: BTreeMap<String, u64>,
}

impl Wire {
    /// What was sent between `before` and `self`.
    pub fn since(&self, before: &Wire) -> Wire {
        let minus = |now: &BTreeMap<String, u64>, then: &BTreeMap<String, u64>| -> BTreeMap<String, u64> {
            now.iter().map(|(k, v)| (k.clone(), v.saturating_sub(then.get(k).copied().unwrap_or(0)))).collect()
        };
        Wire { nodes: self.nodes.min(before.nodes), sent: minus(&self.sent, &before.sent), to_router: minus(&self.to_router, &before.to_router) }
    }

    pub fn get(&self, kind: &str) -> u64 {
        self.sent.get(kind).copied().unwrap_or(0)
    }

    /// Barrier messages of either barrier.
    pub fn barrier(&self) -> u64 {
        BARRIER.iter().map(|k| self.get(k)).sum()
    }

    /// Barrier messages between robots (not those central received and dropped).
    pub fn barrier_between_robots(&self) -> u64 {
        BARRIER.iter().map(|k| self.get(k).saturating_sub(self.to_router.get(*k).copied().unwrap_or(0))).sum()
    }

    pub fn total(&self) -> u64 {
        self.sent.values().sum()
    }
}

const BARRIER: [&str; 3] = ["sync", "arrive", "release"];

/// Reads every node's counters (peers and routers), waiting at most `timeout` for answers.
pub async fn read(client: &Client, timeout: Duration) -> anyhow::Result<Wire> {
    let mut wire = Wire::default();
    for whatami in ["peer", "router"] {
        let replies = client
            .session()
            .get(wire_stats_selector(whatami))
            .consolidation(ConsolidationMode::None)
            .timeout(timeout)
            .await
            .map_err(|e| anyhow!("admin query: {e}"))?;
        while let Ok(reply) = replies.recv_async().await {
            let Ok(sample) = reply.result() else { continue };
            let Ok(json) = serde_json::from_slice::<serde_json::Value>(&sample.payload().to_bytes()) else { continue };
            if add(&mut wire.sent, &json, "tx") {
                wire.nodes += 1;
                if whatami == "router" {
                    add(&mut wire.to_router, &json, "rx");
                }
            }
        }
    }
    Ok(wire)
}

/// Adds one node's sent (`dir` = `tx`) or received (`rx`) messages from its record
/// (`stats_filtered`: one entry per key of [`WIRE_KINDS`]); false if it has none (a node without
/// `wire_stats`).
fn add(sent: &mut BTreeMap<String, u64>, node: &serde_json::Value, dir: &str) -> bool {
    let Some(filtered) = node.get("stats_filtered").and_then(|f| f.as_array()) else { return false };
    for entry in filtered {
        let Some(kind) = entry.get("key").and_then(|k| k.as_str()).and_then(|k| WIRE_KINDS.iter().find(|(_, key)| *key == k)).map(|(kind, _)| *kind) else {
            continue;
        };
        let stats = &entry["stats"];
        let n: u64 = ["put", "query", "reply"].iter().filter_map(|m| stats[format!("{dir}_z_{m}_msgs")]["user"].as_u64()).sum();
        *sent.entry(kind.to_string()).or_insert(0) += n;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_record_adds_its_sends_per_kind() {
        let key = |kind: &str| WIRE_KINDS.iter().find(|(k, _)| *k == kind).map(|(_, key)| *key).expect("a kind");
        let node = serde_json::json!({
            "zid": "x",
            "stats_filtered": [
                {"key": key("sync"), "stats": {"tx_z_put_msgs": {"admin": 0, "user": 12}, "rx_z_put_msgs": {"admin": 0, "user": 40}}},
                {"key": key("command"), "stats": {"tx_z_query_msgs": {"admin": 0, "user": 2}, "tx_z_reply_msgs": {"admin": 0, "user": 3}}},
                {"key": "other/**", "stats": {"tx_z_put_msgs": {"admin": 0, "user": 99}}}
            ]
        });
        let mut sent = BTreeMap::new();
        assert!(add(&mut sent, &node, "tx"));
        assert!(add(&mut sent, &node, "tx"));
        assert!(!add(&mut sent, &serde_json::json!({"zid": "y"}), "tx"));
        let mut to_router = BTreeMap::new();
        add(&mut to_router, &node, "rx");
        let w = Wire { nodes: 2, sent, to_router };
        assert_eq!((w.get("sync"), w.get("command"), w.total(), w.barrier()), (24, 10, 34, 24));
        assert_eq!(w.to_router["sync"], 40);
        assert_eq!(w.barrier_between_robots(), 0, "never below zero");
        let later = Wire { nodes: 2, sent: [("sync".to_string(), 30)].into(), to_router: [("sync".to_string(), 41)].into() };
        assert_eq!((later.since(&w).get("sync"), later.since(&w).barrier_between_robots()), (6, 5));
    }
}
