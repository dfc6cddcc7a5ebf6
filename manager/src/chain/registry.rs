//! One node's replicas of every chain-replicated value it takes part in, keyed by name (the
//! mission), and what it remembers of values it no longer replicates (tombs): the highest promise
//! it made, so a replica created again never votes below it, and whether the value ended, so a
//! straggler that still votes for it is told to end too. Pure: events in, commands out.

use std::collections::{BTreeMap, BTreeSet};

use super::{Command, Event, Msg, Params, Replica};

/// Seconds a node remembers a value it no longer replicates (a straggler of an ended mission is
/// long gone by then), and how many such values at most.
pub const TOMB_LIFETIME_S: f64 = 3600.0;
pub const MAX_TOMBS: usize = 10_000;

/// What a node remembers of a value it no longer replicates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tomb {
    pub promised: u64,
    pub ended: bool,
}

/// Every replica on one node.
#[derive(Debug, Clone)]
pub struct Registry<S> {
    me: String,
    p: Params,
    /// When this node (process) started: its replicas do not vote during `p.quarantine`.
    born: f64,
    replicas: BTreeMap<String, Replica<S>>,
    tombs: BTreeMap<String, Tomb>,
    /// When each tomb was last written: tombs are forgotten after [`TOMB_LIFETIME_S`].
    tomb_since: BTreeMap<String, f64>,
    /// Other nodes whose liveliness is up.
    alive: BTreeSet<String>,
}

impl<S: Clone> Registry<S> {
    pub fn new(me: &str, p: Params, born: f64) -> Self {
        Registry { me: me.to_string(), p, born, replicas: BTreeMap::new(), tombs: BTreeMap::new(), tomb_since: BTreeMap::new(), alive: BTreeSet::new() }
    }

    pub fn me(&self) -> &str {
        &self.me
    }
    pub fn replica(&self, name: &str) -> Option<&Replica<S>> {
        self.replicas.get(name)
    }
    pub fn names(&self) -> impl Iterator<Item = &String> {
        self.replicas.keys()
    }
    pub fn tomb(&self, name: &str) -> Option<Tomb> {
        self.tombs.get(name).copied()
    }
    /// Other nodes alive, as the registry was told.
    pub fn alive(&self) -> &BTreeSet<String> {
        &self.alive
    }

    /// The replica of `name`, created with what this node remembers of it.
    fn replica_mut(&mut self, now: f64, name: &str) -> &mut Replica<S> {
        let promised = self.tombs.get(name).map_or(0, |t| t.promised);
        let (me, p, born, alive) = (&self.me, self.p, self.born, &self.alive);
        self.replicas.entry(name.to_string()).or_insert_with(|| {
            let mut r = Replica::new(me, p, born, now, promised);
            for n in alive {
                let _ = r.handle(now, Event::Alive(n.clone()));
            }
            r
        })
    }

    /// Creates `name` with this node as its head (the first configuration) and `state`.
    pub fn create(&mut self, now: f64, name: &str, replicas: Vec<String>, state: S) -> Vec<Command<S>> {
        self.tombs.remove(name);
        self.replicas.remove(name);
        let cmds = self.replica_mut(now, name).handle(now, Event::Create { replicas, state });
        self.settle(now, name, cmds)
    }

    /// A chain message for `name` from `from`. A node that no longer holds the value creates a
    /// replica only for a vote or an update (it is being asked to join a chain); a vote for a
    /// value that ended here is answered with the end; anything else for a value it does not
    /// hold is dropped.
    pub fn receive(&mut self, now: f64, name: &str, from: String, msg: Msg<S>) -> Vec<Command<S>> {
        if !self.replicas.contains_key(name) {
            match (&msg, self.tombs.get(name)) {
                (Msg::Vote { .. }, Some(t)) if t.ended => {
                    return vec![Command::Send { to: from, msg: Msg::End { epoch: u64::MAX } }];
                }
                // A head replicating to us: we are (again) in its chain.
                (Msg::Update { .. }, Some(_)) => {
                    self.tombs.remove(name);
                }
                (Msg::Vote { .. } | Msg::Update { .. }, _) => {}
                _ => return vec![],
            }
        }
        let cmds = self.replica_mut(now, name).handle(now, Event::Recv { from, msg });
        self.settle(now, name, cmds)
    }

    /// An event for the existing replica of `name` (`Propose`, `Pool`, `End`); nothing if none.
    pub fn handle(&mut self, now: f64, name: &str, ev: Event<S>) -> Vec<Command<S>> {
        let ended = matches!(ev, Event::End);
        let Some(r) = self.replicas.get_mut(name) else { return vec![] };
        let cmds = r.handle(now, ev);
        if ended {
            let t = self.tombs.entry(name.to_string()).or_default();
            t.ended = true;
            self.tomb_since.insert(name.to_string(), now);
        }
        self.settle(now, name, cmds)
    }

    /// Another node's liveliness changed: every replica hears of it.
    pub fn liveliness(&mut self, now: f64, node: &str, up: bool) -> Vec<(String, Vec<Command<S>>)> {
        if node == self.me {
            return vec![];
        }
        if up {
            self.alive.insert(node.to_string());
        } else {
            self.alive.remove(node);
        }
        self.each(now, |n| if up { Event::Alive(n.to_string()) } else { Event::Gone(n.to_string()) }, node)
    }

    /// Time passes for every replica (and old tombs are forgotten).
    pub fn tick(&mut self, now: f64) -> Vec<(String, Vec<Command<S>>)> {
        self.prune_tombs(now);
        self.each(now, |_| Event::Tick, "")
    }

    fn each(&mut self, now: f64, ev: impl Fn(&str) -> Event<S>, node: &str) -> Vec<(String, Vec<Command<S>>)> {
        let names: Vec<String> = self.replicas.keys().cloned().collect();
        let mut out = Vec::new();
        for name in names {
            let cmds = self.replicas.get_mut(&name).map(|r| r.handle(now, ev(node))).unwrap_or_default();
            let cmds = self.settle(now, &name, cmds);
            if !cmds.is_empty() {
                out.push((name, cmds));
            }
        }
        out
    }

    /// Bookkeeping the commands call for: a retired replica becomes a tomb (its promise kept,
    /// and whether it was retired by an end). The commands are returned as they are.
    fn settle(&mut self, now: f64, name: &str, cmds: Vec<Command<S>>) -> Vec<Command<S>> {
        if cmds.iter().any(|c| matches!(c, Command::Retired)) {
            if let Some(r) = self.replicas.remove(name) {
                let t = self.tombs.entry(name.to_string()).or_default();
                t.promised = t.promised.max(r.promised());
                t.ended |= r.ended();
                self.tomb_since.insert(name.to_string(), now);
            }
        }
        cmds
    }

    /// Forgets tombs older than [`TOMB_LIFETIME_S`], and the oldest beyond [`MAX_TOMBS`].
    fn prune_tombs(&mut self, now: f64) {
        self.tomb_since.retain(|_, t| now - *t < TOMB_LIFETIME_S);
        if self.tomb_since.len() > MAX_TOMBS {
            let mut by_age: Vec<(f64, String)> = self.tomb_since.iter().map(|(n, t)| (*t, n.clone())).collect();
            by_age.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (_, n) in by_age.into_iter().take(self.tomb_since.len() - MAX_TOMBS) {
                self.tomb_since.remove(&n);
            }
        }
        let keep = &self.tomb_since;
        self.tombs.retain(|n, _| keep.contains_key(n));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Reg = Registry<Vec<u32>>;

    fn p() -> Params {
        Params { quarantine: 0.0, ..Params::default() }
    }

    #[test]
    fn only_votes_and_updates_create_a_replica() {
        let mut r = Reg::new("b", p(), 0.0);
        assert!(r.receive(0.0, "m", "a".into(), Msg::Ack { epoch: 1, seq: 1 }).is_empty());
        assert!(r.replica("m").is_none());
        let cfg = super::super::Config { epoch: 1, chain: vec!["a".into(), "b".into()] };
        let out = r.receive(0.0, "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        assert_eq!(out, vec![Command::Send { to: "a".into(), msg: Msg::Ack { epoch: 1, seq: 0 } }]);
        assert_eq!(r.replica("m").and_then(|x| x.state()), Some(&vec![1]));
    }

    #[test]
    fn an_ended_value_is_ended_again_for_stragglers_and_its_promise_kept() {
        let mut r = Reg::new("b", p(), 0.0);
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into()] };
        r.receive(0.0, "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        let out = r.receive(0.1, "m", "a".into(), Msg::End { epoch: 3 });
        assert!(out.contains(&Command::Retired));
        assert!(r.replica("m").is_none());
        assert_eq!(r.tomb("m"), Some(Tomb { promised: 3, ended: true }));
        let vote = Msg::Vote { proposal: super::super::Config { epoch: 4, chain: vec!["c".into(), "b".into()] }, base: vec![], last: (3, 0) };
        assert_eq!(r.receive(0.2, "m", "c".into(), vote), vec![Command::Send { to: "c".into(), msg: Msg::End { epoch: u64::MAX } }]);
        assert!(r.replica("m").is_none(), "no replica for a straggler's vote");
    }

    #[test]
    fn tombs_are_forgotten_after_their_lifetime() {
        let mut r = Reg::new("b", p(), 0.0);
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into()] };
        r.receive(0.0, "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        r.receive(0.1, "m", "a".into(), Msg::End { epoch: 3 });
        r.tick(100.0);
        assert!(r.tomb("m").is_some(), "kept while stragglers may come");
        r.tick(0.1 + TOMB_LIFETIME_S);
        assert_eq!(r.tomb("m"), None);
    }
}
