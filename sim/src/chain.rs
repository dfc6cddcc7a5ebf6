//! A seeded, deterministic message-level simulation of chain replication: an in-memory network
//! with delay, loss, duplication, partitions, crashes and restarts (a restart loses memory); each
//! node is the production [`Registry`] (the one mission hosts use: replicas created for votes and
//! updates, promises and ends remembered while the process lives), and heads keep proposing new
//! states of a log, so a lost commit is visible. The invariants are checked in [`Invariants`]; a run
//! returns the first violation with the seed that replays it.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use mrmm_core::mission::chain::{Command, Config, Disk, Event, Msg, Params, Registry, Replica, Version};
use mrmm_proto::{MissionName, NodeId, Time};

/// The value replicated in the simulation: the ids of every update, in order.
pub type Log = Vec<u64>;

/// How hostile the simulated world is.
#[derive(Debug, Clone, Copy)]
pub struct World {
    pub nodes: usize,
    /// Simulated seconds with faults, then `quiet` seconds healed.
    pub duration: f64,
    pub quiet: f64,
    pub loss: f64,
    pub duplicate: f64,
    /// Message delay, uniform in `[0, max_delay]` seconds.
    pub max_delay: f64,
    /// Mean seconds between two crashes (of one node, restarted later), 0 for none.
    pub crash_every: f64,
    /// Mean seconds between two partitions, 0 for none.
    pub partition_every: f64,
    /// How long a partition lasts at most.
    pub partition_for: f64,
    /// Liveliness loss is seen this late after a partition (the lease).
    pub lease: f64,
    /// Nodes keep their chain state on disk (a durable [`Registry`]): a restart loses nothing
    /// persisted, several nodes may be down at once, and now and then every node goes down
    /// together (a power cycle).
    pub durable: bool,
}

impl World {
    /// A world for seed `seed`: a mix of faults drawn from the seed.
    pub fn for_seed(seed: u64) -> World {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
        World {
            nodes: r.gen_range(3..=6),
            duration: 30.0,
            quiet: 20.0,
            loss: [0.0, 0.01, 0.05, 0.2][r.gen_range(0..4)],
            duplicate: [0.0, 0.02][r.gen_range(0..2)],
            max_delay: [0.002, 0.02, 0.2][r.gen_range(0..3)],
            crash_every: [0.0, 3.0, 8.0][r.gen_range(0..3)],
            partition_every: [0.0, 4.0, 10.0][r.gen_range(0..3)],
            partition_for: 6.0,
            lease: 1.0,
            durable: r.gen_bool(0.5),
        }
    }
}

/// What a run found.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub seed: u64,
    pub leads: usize,
    pub commits: usize,
    pub crashes: usize,
    pub partitions: usize,
    pub messages: u64,
    /// Heads at the end, after the quiet period.
    pub heads_at_end: usize,
    /// Whether a majority of the final chain kept its memory (else the value may be lost).
    pub recoverable: bool,
    /// Whether the nodes had disks ([`World::durable`]).
    pub durable: bool,
    /// The trace, when asked for with [`Sim::with_trace`].
    pub trace: Vec<String>,
}

/// The invariants, each checked in one place.
#[derive(Debug, Default)]
pub struct Invariants {
    heads: BTreeMap<u64, String>,
    committed: BTreeSet<u64>,
}

impl Invariants {
    /// At most one head per epoch; a new head holds every committed update.
    pub fn lead(&mut self, node: &str, config: &Config, state: &Log) -> Result<(), String> {
        if let Some(other) = self.heads.get(&config.epoch).filter(|o| *o != node) {
            return Err(format!("two heads in epoch {}: {other} and {node}", config.epoch));
        }
        self.heads.insert(config.epoch, node.to_string());
        self.holds_committed(node, state)
    }

    /// No acknowledged update is ever lost: every commit extends all earlier ones.
    pub fn commit(&mut self, node: &str, state: &Log) -> Result<(), String> {
        self.holds_committed(node, state)?;
        self.committed.extend(state.iter().copied());
        Ok(())
    }

    fn holds_committed(&self, node: &str, state: &Log) -> Result<(), String> {
        let have: BTreeSet<u64> = state.iter().copied().collect();
        match self.committed.iter().find(|id| !have.contains(id)) {
            Some(id) => Err(format!("{node} leads or commits without committed update {id}")),
            None => Ok(()),
        }
    }
}

enum Delivery {
    Msg { from: usize, to: usize, msg: Msg<Log> },
    Live { at: usize, about: usize, up: bool },
    Restart(usize),
    Heal,
}

struct Node {
    name: String,
    up: bool,
    born: f64,
    /// The node's replicas (one mission, [`MISSION`]); lost in a crash.
    registry: Registry<Log>,
    /// States this node proposed or led with, by version (to check commits).
    history: BTreeMap<Version, Log>,
    next_proposal: f64,
    /// What a durable node persisted, as its [`Command::Persist`]s wrote it; kept across crashes.
    disk: BTreeMap<MissionName, Disk<Log>>,
}

/// One simulation run.
pub struct Sim {
    seed: u64,
    w: World,
    p: Params,
    rng: ChaCha8Rng,
    now: f64,
    nodes: Vec<Node>,
    queue: BinaryHeap<(Reverse<u64>, Reverse<u64>, usize)>,
    pending: Vec<Option<Delivery>>,
    seq: u64,
    side: Vec<bool>,
    partitioned: bool,
    inv: Invariants,
    next_id: u64,
    report: Report,
    /// Per pair, the time of the last scheduled liveliness change (keeps them in order).
    live_at: BTreeMap<(usize, usize), f64>,
    trace: Option<Vec<String>>,
}

const TICK: f64 = 0.01;
/// The one value the simulation replicates.
const MISSION: &str = "m";

impl Node {
    fn replica(&self) -> Option<&Replica<Log>> {
        self.registry.replica(MISSION)
    }
}

fn ns(t: f64) -> u64 {
    (t * 1e9) as u64
}

impl Sim {
    pub fn new(seed: u64, w: World, p: Params) -> Sim {
        let nodes = (0..w.nodes)
            .map(|i| Node {
                name: format!("n{i}"),
                up: true,
                born: -10.0,
                registry: if w.durable {
                    Registry::restore(&format!("n{i}"), p, Time::from_secs(-10.0), Time::ZERO, [])
                } else {
                    Registry::new(&format!("n{i}"), p, Time::from_secs(-10.0))
                },
                history: BTreeMap::new(),
                next_proposal: 0.0,
                disk: BTreeMap::new(),
            })
            .collect::<Vec<Node>>();
        let mut nodes = nodes;
        let names: Vec<String> = nodes.iter().map(|n| n.name.clone()).collect();
        for n in nodes.iter_mut() {
            for other in &names {
                let _ = n.registry.liveliness(Time::ZERO, other, true);
            }
        }
        Sim {
            seed,
            w,
            p,
            rng: ChaCha8Rng::seed_from_u64(seed),
            now: 0.0,
            nodes,
            queue: BinaryHeap::new(),
            pending: Vec::new(),
            seq: 0,
            side: vec![false; w.nodes],
            partitioned: false,
            inv: Invariants::default(),
            next_id: 1,
            report: Report { seed, durable: w.durable, ..Report::default() },
            live_at: BTreeMap::new(),
            trace: None,
        }
    }

    /// Keeps a readable trace of the run (for replaying a failing seed).
    pub fn with_trace(mut self) -> Self {
        self.trace = Some(Vec::new());
        self
    }
    pub fn trace(&self) -> &[String] {
        self.trace.as_deref().unwrap_or(&[])
    }

    fn log(&mut self, f: impl FnOnce() -> String) {
        if let Some(t) = &mut self.trace {
            t.push(format!("{:8.3} {}", self.now, f()));
        }
    }

    fn schedule(&mut self, at: f64, d: Delivery) {
        self.seq += 1;
        self.pending.push(Some(d));
        self.queue.push((Reverse(ns(at)), Reverse(self.seq), self.pending.len() - 1));
    }

    fn connected(&self, a: usize, b: usize) -> bool {
        self.nodes[a].up && self.nodes[b].up && (!self.partitioned || self.side[a] == self.side[b])
    }

    /// Re-evaluates who sees whom; changes reach each observer after `delay`.
    fn liveliness_changed(&mut self, delay: f64) {
        for a in 0..self.nodes.len() {
            for b in 0..self.nodes.len() {
                if a == b || !self.nodes[a].up {
                    continue;
                }
                let up = self.connected(a, b);
                let at = (self.now + delay).max(self.live_at.get(&(a, b)).copied().unwrap_or(0.0) + 1e-6);
                self.live_at.insert((a, b), at);
                self.schedule(at, Delivery::Live { at: a, about: b, up });
            }
        }
    }

    /// Runs the simulation; `Err` names the violated invariant, the seed and the time.
    pub fn run(mut self) -> Result<Report, (String, Vec<String>)> {
        match self.run_inner() {
            Ok(()) => {
                self.report.trace = self.trace.take().unwrap_or_default();
                Ok(self.report)
            }
            Err(e) => {
                let msg = format!("seed {} at t={:.3}: {e}", self.seed, self.now);
                Err((msg, self.trace.take().unwrap_or_default()))
            }
        }
    }

    fn run_inner(&mut self) -> Result<(), String> {
        let end = self.w.duration + self.w.quiet;
        let first: Vec<NodeId> = self.nodes.iter().skip(1).take(self.p.k).map(|n| NodeId::from(&n.name)).collect();
        let cmds = self.nodes[0].registry.create(Time::ZERO, MISSION, first, vec![], 0);
        self.apply(0, cmds)?;
        let mut next_crash = self.draw(self.w.crash_every);
        let mut next_partition = self.draw(self.w.partition_every);
        let mut next_tick = TICK;
        while self.now < end {
            // Next thing: a delivery or a tick.
            let next_delivery = self.queue.peek().map(|(Reverse(t), _, _)| *t as f64 / 1e9);
            if next_delivery.is_some_and(|t| t <= next_tick) {
                let Some((Reverse(t), _, i)) = self.queue.pop() else { break };
                self.now = t as f64 / 1e9;
                if let Some(d) = self.pending[i].take() {
                    self.deliver(d)?;
                }
                continue;
            }
            self.now = next_tick;
            next_tick += TICK;
            let faulty = self.now < self.w.duration;
            if faulty && self.now >= next_crash {
                next_crash = self.now + self.draw(self.w.crash_every);
                if self.w.durable && self.rng.gen_bool(0.2) {
                    // A power cycle: every node down at once, each back after its own delay.
                    self.log(|| "power cycle".to_string());
                    for i in 0..self.nodes.len() {
                        if self.nodes[i].up {
                            self.crash(i);
                            let back = self.now + self.rng.gen_range(0.5..4.0);
                            self.schedule(back, Delivery::Restart(i));
                        }
                    }
                } else if self.w.durable || self.nodes.iter().all(|n| n.up) {
                    // Without a disk, at most one node down at a time, so the chain's majority
                    // keeps its memory.
                    let i = self.rng.gen_range(0..self.nodes.len());
                    if self.nodes[i].up {
                        self.crash(i);
                        let back = self.now + self.rng.gen_range(0.5..4.0);
                        self.schedule(back, Delivery::Restart(i));
                    }
                }
            }
            if faulty && self.now >= next_partition && !self.partitioned {
                next_partition = self.now + self.draw(self.w.partition_every);
                let n = self.nodes.len();
                self.side = (0..n).map(|_| self.rng.gen_bool(0.5)).collect();
                self.partitioned = true;
                self.report.partitions += 1;
                self.log(|| "partition".to_string());
                let lease = self.w.lease;
                self.liveliness_changed(lease);
                let heal = self.now + self.rng.gen_range(0.5..self.w.partition_for);
                self.schedule(heal.min(self.w.duration), Delivery::Heal);
            }
            for i in 0..self.nodes.len() {
                if !self.nodes[i].up {
                    continue;
                }
                for (_, cmds) in self.nodes[i].registry.tick(Time::from_secs(self.now)) {
                    self.apply(i, cmds)?;
                }
                self.maybe_propose(i)?;
            }
        }
        self.finish()
    }

    fn draw(&mut self, mean: f64) -> f64 {
        if mean <= 0.0 {
            return f64::INFINITY;
        }
        self.rng.gen_range(0.2 * mean..1.8 * mean)
    }

    fn finish(&mut self) -> Result<(), String> {
        let heads: Vec<&Node> = self.nodes.iter().filter(|n| n.up && n.replica().is_some_and(|r| r.is_head())).collect();
        self.report.heads_at_end = heads.len();
        // The newest configuration any node knows, and whether a majority of it kept its state.
        let newest = self.nodes.iter().filter_map(|n| n.replica()?.config().cloned()).max_by_key(|c| c.epoch);
        self.report.recoverable =
            newest.is_some_and(|c| c.majority(|m| self.nodes.iter().any(|n| n.name == m && n.replica().is_some_and(|r| r.state().is_some()))));
        if heads.len() > 1 {
            let names: Vec<String> = heads.iter().map(|n| n.name.clone()).collect();
            return Err(format!("{} heads after healing: {}", heads.len(), names.join(", ")));
        }
        Ok(())
    }

    fn crash(&mut self, i: usize) {
        self.report.crashes += 1;
        let n = &mut self.nodes[i];
        n.up = false;
        n.registry = Registry::new(&n.name, self.p, Time::from_secs(f64::NAN));
        n.history.clear();
        let name = n.name.clone();
        self.log(|| format!("crash {name}"));
        self.liveliness_changed(0.05);
    }

    fn deliver(&mut self, d: Delivery) -> Result<(), String> {
        match d {
            Delivery::Msg { from, to, msg } => {
                if !self.connected(from, to) {
                    return Ok(());
                }
                self.report.messages += 1;
                let from_name = self.nodes[from].name.clone();
                if let Some(t) = &mut self.trace {
                    t.push(format!("{:8.3} {from_name} -> n{to}: {}", self.now, short(&msg)));
                }
                let now = self.now;
                let cmds = self.nodes[to].registry.receive(Time::from_secs(now), MISSION, from_name.into(), msg);
                self.apply(to, cmds)
            }
            Delivery::Live { at, about, up } => {
                if !self.nodes[at].up {
                    return Ok(());
                }
                let name = self.nodes[about].name.clone();
                let now = self.now;
                for (_, cmds) in self.nodes[at].registry.liveliness(Time::from_secs(now), &name, up) {
                    self.apply(at, cmds)?;
                }
                Ok(())
            }
            Delivery::Restart(i) => {
                let now = self.now;
                let p = self.p;
                let n = &mut self.nodes[i];
                n.up = true;
                n.born = now;
                n.registry = if self.w.durable {
                    Registry::restore(&n.name, p, Time::from_secs(now), Time::from_secs(now), n.disk.clone())
                } else {
                    Registry::new(&n.name, p, Time::from_secs(now))
                };
                let name = n.name.clone();
                self.log(|| format!("restart {name}"));
                for j in 0..self.nodes.len() {
                    if j != i && self.connected(i, j) {
                        let other = self.nodes[j].name.clone();
                        let _ = self.nodes[i].registry.liveliness(Time::from_secs(now), &other, true);
                    }
                }
                self.liveliness_changed(0.05);
                Ok(())
            }
            Delivery::Heal => {
                self.partitioned = false;
                self.log(|| "heal".to_string());
                self.liveliness_changed(0.05);
                Ok(())
            }
        }
    }

    fn maybe_propose(&mut self, i: usize) -> Result<(), String> {
        let now = self.now;
        let leads = self.nodes[i].replica().is_some_and(|r| r.leads());
        if !leads || now < self.nodes[i].next_proposal {
            return Ok(());
        }
        let gap = self.rng.gen_range(0.05..0.5);
        self.nodes[i].next_proposal = now + gap;
        let id = self.next_id;
        self.next_id += 1;
        let mut log = self.nodes[i].replica().and_then(|r| r.state()).cloned().unwrap_or_default();
        log.push(id);
        let cmds = self.nodes[i].registry.handle(Time::from_secs(now), MISSION, Event::Propose(log));
        self.apply(i, cmds)
    }

    fn apply(&mut self, i: usize, cmds: Vec<Command<Log>>) -> Result<(), String> {
        // Remember what a leading node holds at each version, to check what it later commits
        // (every change of its state is a `handle` whose commands come here).
        if let Some(r) = self.nodes[i].replica().filter(|r| r.leads()) {
            if let Some(s) = r.state() {
                let (v, s) = (r.version(), s.clone());
                self.nodes[i].history.entry(v).or_insert(s);
            }
        }
        for c in cmds {
            match c {
                Command::Send { to, msg } => {
                    let Some(j) = to.as_str().strip_prefix('n').and_then(|s| s.parse::<usize>().ok()).filter(|j| *j < self.nodes.len()) else {
                        return Err(format!("message to unknown node {to}"));
                    };
                    if self.rng.gen_bool(self.w.loss.min(1.0)) {
                        continue;
                    }
                    let copies = if self.rng.gen_bool(self.w.duplicate.min(1.0)) { 2 } else { 1 };
                    for _ in 0..copies {
                        let at = self.now + self.rng.gen_range(0.0..=self.w.max_delay);
                        self.schedule(at, Delivery::Msg { from: i, to: j, msg: msg.clone() });
                    }
                }
                Command::Lead { config, state } => {
                    self.report.leads += 1;
                    let name = self.nodes[i].name.clone();
                    self.log(|| format!("{name} leads epoch {} chain {:?}", config.epoch, config.chain));
                    self.inv.lead(&name, &config, &state)?;
                    // Heads learn the pool from the system: every node but themselves.
                    let pool: Vec<NodeId> = (0..self.nodes.len()).filter(|j| *j != i).map(|j| NodeId::from(format!("n{j}"))).collect();
                    let _ = self.nodes[i].registry.handle(Time::from_secs(self.now), MISSION, Event::Pool { nodes: pool, k: self.p.k });
                }
                Command::Committed { epoch, seq } => {
                    self.report.commits += 1;
                    let name = self.nodes[i].name.clone();
                    // A head that changed its own chain keeps proposing: its state at (epoch, 0)
                    // is its newest one.
                    let state = match self.nodes[i].history.get(&(epoch, seq)) {
                        Some(s) => s.clone(),
                        None => match self.nodes[i].replica().filter(|r| r.version() == (epoch, seq)).and_then(|r| r.state()) {
                            Some(s) => s.clone(),
                            None => return Err(format!("{name} committed ({epoch}, {seq}) it never held")),
                        },
                    };
                    self.inv.commit(&name, &state)?;
                }
                Command::StepDown => {
                    let name = self.nodes[i].name.clone();
                    self.log(|| format!("{name} steps down"));
                }
                // The registry keeps the promise and forgets the replica.
                Command::Retired => {}
                Command::Persist(d) => {
                    if !self.w.durable {
                        return Err("a registry without a disk asked to persist".into());
                    }
                    match d {
                        Disk::Forget => self.nodes[i].disk.remove(MISSION),
                        d => self.nodes[i].disk.insert(MISSION.into(), d),
                    };
                }
            }
        }
        Ok(())
    }
}

fn short(m: &Msg<Log>) -> String {
    match m {
        Msg::Update { config, seq, state } => format!("Update e{} s{} {:?} len {}", config.epoch, seq, config.chain, state.len()),
        Msg::Beat { config, seq } => format!("Beat e{} s{} {:?}", config.epoch, seq, config.chain),
        other => format!("{other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_calm_world_has_one_head_and_commits() {
        let w = World { crash_every: 0.0, partition_every: 0.0, loss: 0.0, duplicate: 0.0, ..World::for_seed(1) };
        let r = Sim::new(1, w, Params::default()).run().map_err(|e| e.0).expect("no violation");
        assert_eq!(r.heads_at_end, 1);
        assert_eq!(r.leads, 1);
        assert!(r.commits > 50, "{r:?}");
    }
}
