//! How busy a node's loop is: the share of wall time it spent deciding (its core's `handle`) and
//! carrying out what was decided, by kind of event. Reported once per period (at info when the
//! loop was busy more than half the time, at debug otherwise); a single step slower than
//! [`SLOW_STEP`] is logged at once with its kind.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// A step (one event decided and carried out) slower than this is logged on its own.
pub const SLOW_STEP: Duration = Duration::from_millis(200);
/// How often the load is reported.
pub const PERIOD: Duration = Duration::from_secs(10);

/// Time spent per kind of event since the last report.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
struct Spent {
    count: u64,
    deciding: Duration,
    doing: Duration,
}

/// The loop's load meter.
#[derive(Debug)]
pub struct LoopLoad {
    node: String,
    since: Instant,
    kinds: BTreeMap<&'static str, Spent>,
}

impl LoopLoad {
    pub fn new(node: impl Into<String>) -> LoopLoad {
        LoopLoad { node: node.into(), since: Instant::now(), kinds: BTreeMap::new() }
    }

    /// One step: `kind` of event, `deciding` spent in the core, `doing` carrying out its commands.
    pub fn step(&mut self, kind: &'static str, deciding: Duration, doing: Duration) {
        let s = self.kinds.entry(kind).or_default();
        s.count += 1;
        s.deciding += deciding;
        s.doing += doing;
        if deciding + doing > SLOW_STEP {
            tracing::warn!(node = %self.node, kind, deciding_ms = deciding.as_millis() as u64, doing_ms = doing.as_millis() as u64, "slow step: the loop was held up");
        }
        if self.since.elapsed() >= PERIOD {
            self.report();
        }
    }

    fn report(&mut self) {
        let wall = self.since.elapsed();
        let busy: Duration = self.kinds.values().map(|s| s.deciding + s.doing).sum();
        let share = busy.as_secs_f64() / wall.as_secs_f64().max(1e-9);
        let line = summary(&self.kinds);
        if share > 0.5 {
            tracing::info!(node = %self.node, busy_pct = (share * 100.0).round() as u64, "loop busy over the last {:.0} s: {line}", wall.as_secs_f64());
        } else {
            tracing::debug!(node = %self.node, busy_pct = (share * 100.0).round() as u64, "loop load over the last {:.0} s: {line}", wall.as_secs_f64());
        }
        self.kinds.clear();
        self.since = Instant::now();
    }
}

/// The kinds that took the most time, most first: `telemetry 4123× 1.2+0.3 s, …`.
fn summary(kinds: &BTreeMap<&'static str, Spent>) -> String {
    let mut by_time: Vec<(&&str, &Spent)> = kinds.iter().collect();
    by_time.sort_by_key(|(_, s)| std::cmp::Reverse(s.deciding + s.doing));
    by_time
        .iter()
        .take(5)
        .map(|(k, s)| format!("{k} {}× {:.2}+{:.2} s", s.count, s.deciding.as_secs_f64(), s.doing.as_secs_f64()))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_puts_the_costliest_kind_first() {
        let mut kinds = BTreeMap::new();
        kinds.insert("tick", Spent { count: 40, deciding: Duration::from_millis(10), doing: Duration::ZERO });
        kinds.insert("telemetry", Spent { count: 4000, deciding: Duration::from_millis(1200), doing: Duration::from_millis(300) });
        assert_eq!(summary(&kinds), "telemetry 4000× 1.20+0.30 s, tick 40× 0.01+0.00 s");
    }
}
