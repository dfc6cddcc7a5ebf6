//! One node's replicas of every chain-replicated value it takes part in, keyed by name (the
//! mission), and what it remembers of values it no longer replicates (tombs): the highest promise
//! it made, so a replica created again never votes below it, and whether the value ended, so a
//! straggler that still votes for it is told to end too. Pure: events in, commands out.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::chain::lineage_of;
use mrmm_proto::{MissionName, NodeId, Time};

use super::replica::Fingerprint;
use super::{Command, Event, Msg, Params, Replica, Stored};

/// Seconds a node remembers a value it no longer replicates (a straggler of an ended mission is
/// long gone by then), and how many such values at most.
pub const TOMB_LIFETIME_S: f64 = 3600.0;
pub const MAX_TOMBS: usize = 10_000;

/// What a node remembers of a value it no longer replicates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Tomb {
    pub promised: u64,
    pub ended: bool,
}

/// What a durable node keeps on disk for one value, under its name.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Disk<S> {
    Replica(Stored<S>),
    Tomb(Tomb),
    /// Nothing any more (a tomb forgotten).
    Forget,
}

/// Every replica on one node.
#[derive(Debug, Clone)]
pub struct Registry<S> {
    me: NodeId,
    p: Params,
    /// When this node (process) started: its replicas do not vote during `p.quarantine`.
    born: Time,
    replicas: BTreeMap<MissionName, Replica<S>>,
    tombs: BTreeMap<MissionName, Tomb>,
    /// When each tomb was last written: tombs are forgotten after [`TOMB_LIFETIME_S`].
    tomb_since: BTreeMap<MissionName, Time>,
    /// Other nodes whose liveliness is up.
    alive: BTreeSet<NodeId>,
    /// Whether every change of what a replica must remember is put out as [`Command::Persist`].
    durable: bool,
}

impl<S: Clone> Registry<S> {
    pub fn new(me: &str, p: Params, born: Time) -> Self {
        Registry {
            me: me.into(),
            p,
            born,
            replicas: BTreeMap::new(),
            tombs: BTreeMap::new(),
            tomb_since: BTreeMap::new(),
            alive: BTreeSet::new(),
            durable: false,
        }
    }

    /// A durable registry brought back from what it persisted (empty on a first start): every
    /// change it makes from now on is put out as [`Command::Persist`] before what it leads to.
    /// Its replicas vote at once: their promises were on disk, so `p.quarantine` is not needed.
    pub fn restore(me: &str, p: Params, born: Time, now: Time, disk: impl IntoIterator<Item = (MissionName, Disk<S>)>) -> Self {
        let p = Params { quarantine: 0.0, ..p };
        let mut reg = Registry::new(me, p, born);
        reg.durable = true;
        for (name, d) in disk {
            match d {
                Disk::Replica(stored) if stored.ended => {
                    reg.tombs.insert(name.clone(), Tomb { promised: stored.promised, ended: true });
                    reg.tomb_since.insert(name, now);
                }
                Disk::Replica(stored) => {
                    reg.replicas.insert(name, Replica::restore(me, p, born, now, stored));
                }
                Disk::Tomb(t) => {
                    reg.tombs.insert(name.clone(), t);
                    reg.tomb_since.insert(name, now);
                }
                Disk::Forget => {}
            }
        }
        reg
    }

    /// Whether this registry persists what it must remember.
    pub fn durable(&self) -> bool {
        self.durable
    }

    pub fn me(&self) -> &str {
        self.me.as_str()
    }
    pub fn replica(&self, name: &str) -> Option<&Replica<S>> {
        self.replicas.get(name)
    }
    pub fn names(&self) -> impl Iterator<Item = &MissionName> {
        self.replicas.keys()
    }
    pub fn tomb(&self, name: &str) -> Option<Tomb> {
        self.tombs.get(name).copied()
    }
    /// Other nodes alive, as the registry was told.
    pub fn alive(&self) -> &BTreeSet<NodeId> {
        &self.alive
    }

    /// The replica of `name`, created with what this node remembers of it.
    fn replica_mut(&mut self, now: Time, name: &str) -> &mut Replica<S> {
        let promised = self.tombs.get(name).map_or(0, |t| t.promised);
        let (me, p, born, alive, durable) = (&self.me, self.p, self.born, &self.alive, self.durable);
        self.replicas.entry(name.into()).or_insert_with(|| {
            let mut r = Replica::new(me.as_str(), p, born, now, promised);
            if durable {
                r = r.durable();
            }
            for n in alive {
                let _ = r.handle(now, Event::Alive(n.clone()));
            }
            r
        })
    }

    /// Creates `name` with this node as its head (the first configuration) and `state`, its
    /// first epoch at least `floor`.
    /// The first epoch is also above the promise this node remembers of an earlier value of that
    /// name (a replica it discarded, a tomb).
    pub fn create(&mut self, now: Time, name: &str, replicas: Vec<NodeId>, state: S, floor: u64) -> Vec<Command<S>> {
        let promised = self.tombs.remove(name).map_or(0, |t| t.promised).max(self.replicas.remove(name).map_or(0, |r| r.promised()));
        let floor = floor.max(promised.saturating_add(1));
        let before = self.mark(name);
        let cmds = self.replica_mut(now, name).handle(now, Event::Create { replicas, state, floor });
        self.settle(now, name, before, cmds)
    }

    /// What this node answers `msg` about `name` when the value ended here (it holds no replica of
    /// it, only the tomb), whoever sent it: a straggler of the ended chain must learn that it
    /// ended, or it could stand again and revive the value.
    pub fn tomb_answer(&self, name: &str, msg: &Msg<S>) -> Option<Msg<S>> {
        if self.replicas.contains_key(name) {
            return None;
        }
        let t = self.tombs.get(name).filter(|t| t.ended)?;
        match msg {
            // (A vote of a newer lineage is not this ended chain's: the value started anew.)
            Msg::Vote { proposal, .. } if lineage_of(proposal.epoch) <= lineage_of(t.promised) => Some(Msg::End { epoch: u64::MAX }),
            // A late update or beat of the chain that ended here (or an older one): it must not
            // bring the value back (a replica made of it could stand and revive an ended mission:
            // found by the system sim, seed 159 with capability changes). Declined, so that a
            // head of a value of the same name created since goes on without us.
            Msg::Update { config, .. } | Msg::Beat { config, .. } if config.epoch <= t.promised => Some(Msg::Decline { epoch: config.epoch }),
            _ => None,
        }
    }

    /// A chain message for `name` from `from`. A node that no longer holds the value creates a
    /// replica only for a vote or an update (it is being asked to join a chain); a vote for a
    /// value that ended here is answered with the end; anything else for a value it does not
    /// hold is dropped. (A beat counts as an update: the node then asks for the state.)
    pub fn receive(&mut self, now: Time, name: &str, from: NodeId, msg: Msg<S>) -> Vec<Command<S>> {
        if !self.replicas.contains_key(name) {
            if let Some(answer) = self.tomb_answer(name, &msg) {
                return vec![Command::Send { to: from, msg: answer }];
            }
            match (&msg, self.tombs.get(name)) {
                // A head replicating to us: we are (again) in its chain.
                (Msg::Update { .. } | Msg::Beat { .. }, Some(_)) => {
                    self.tombs.remove(name);
                }
                (Msg::Vote { .. } | Msg::Update { .. } | Msg::Beat { .. }, _) => {}
                _ => return vec![],
            }
        }
        let before = self.mark(name);
        let cmds = self.replica_mut(now, name).handle(now, Event::Recv { from, msg });
        self.settle(now, name, before, cmds)
    }

    /// An event for the existing replica of `name` (`Propose`, `Pool`, `End`); nothing if none.
    pub fn handle(&mut self, now: Time, name: &str, ev: Event<S>) -> Vec<Command<S>> {
        let ended = matches!(ev, Event::End);
        let before = self.mark(name);
        let Some(r) = self.replicas.get_mut(name) else { return vec![] };
        let cmds = r.handle(now, ev);
        if ended {
            let t = self.tombs.entry(name.into()).or_default();
            t.ended = true;
            self.tomb_since.insert(name.into(), now);
        }
        self.settle(now, name, before, cmds)
    }

    /// Throws away this node's replica of `name` (not while it leads): it is outdated, and a new
    /// chain is about to be created here. Its promise stays, as a tomb, so the new chain's
    /// epochs are above every one it took part in.
    pub fn discard(&mut self, now: Time, name: &str) -> Vec<Command<S>> {
        if self.replicas.get(name).is_none_or(|r| r.leads()) {
            return vec![];
        }
        self.throw_away(now, name)
    }

    /// Throws away this node's replica of `name` although it leads, when it has not been able
    /// to commit for `at_least` seconds (see [`Replica::uncommitted_for`]): its chain lost the
    /// memory of a majority of its nodes, and the value is started anew here, as its next
    /// lineage. Such a head acted on nothing it could not commit. Its promise stays, as a tomb.
    pub fn abandon(&mut self, now: Time, name: &str, at_least: f64) -> Vec<Command<S>> {
        if self.replicas.get(name).and_then(|r| r.uncommitted_for(now)).is_none_or(|s| s < at_least) {
            return vec![];
        }
        self.throw_away(now, name)
    }

    fn throw_away(&mut self, now: Time, name: &str) -> Vec<Command<S>> {
        let before = self.mark(name);
        if let Some(r) = self.replicas.remove(name) {
            let t = self.tombs.entry(name.into()).or_default();
            t.promised = t.promised.max(r.promised());
            self.tomb_since.insert(name.into(), now);
        }
        self.settle(now, name, before, vec![])
    }

    /// Another node's liveliness changed: every replica hears of it.
    pub fn liveliness(&mut self, now: Time, node: &str, up: bool) -> Vec<(MissionName, Vec<Command<S>>)> {
        if node == self.me {
            return vec![];
        }
        if up {
            self.alive.insert(node.into());
        } else {
            self.alive.remove(node);
        }
        self.each(now, |n| if up { Event::Alive(n.into()) } else { Event::Gone(n.into()) }, node)
    }

    /// Time passes for every replica (and old tombs are forgotten).
    pub fn tick(&mut self, now: Time) -> Vec<(MissionName, Vec<Command<S>>)> {
        let forgotten = self.prune_tombs(now);
        let mut out = self.each(now, |_| Event::Tick, "");
        if self.durable {
            out.extend(forgotten.into_iter().map(|n| (n, vec![Command::Persist(Disk::Forget)])));
        }
        out
    }

    fn each(&mut self, now: Time, ev: impl Fn(&str) -> Event<S>, node: &str) -> Vec<(MissionName, Vec<Command<S>>)> {
        let names: Vec<MissionName> = self.replicas.keys().cloned().collect();
        let mut out = Vec::new();
        for name in names {
            let before = self.mark(name.as_str());
            let cmds = self.replicas.get_mut(&name).map(|r| r.handle(now, ev(node))).unwrap_or_default();
            let cmds = self.settle(now, name.as_str(), before, cmds);
            if !cmds.is_empty() {
                out.push((name, cmds));
            }
        }
        out
    }

    /// What a durable registry holds of `name` before an event, to see what the event changed.
    /// (A replica not there counts as a blank one with the tomb's promise: creating one for a
    /// refused vote writes nothing.)
    fn mark(&self, name: &str) -> Option<(Fingerprint, Option<Tomb>)> {
        self.durable.then(|| self.fingerprint(name))
    }

    fn fingerprint(&self, name: &str) -> (Fingerprint, Option<Tomb>) {
        let tomb = self.tombs.get(name).copied();
        let fp = match self.replicas.get(name) {
            Some(r) => r.fingerprint(),
            None => Fingerprint::blank(tomb.map_or(0, |t| t.promised)),
        };
        (fp, tomb)
    }

    /// Bookkeeping the commands call for: a retired replica becomes a tomb (its promise kept,
    /// and whether it was retired by an end). A durable registry puts what changed first, as
    /// [`Command::Persist`]; the commands follow as they are.
    fn settle(&mut self, now: Time, name: &str, before: Option<(Fingerprint, Option<Tomb>)>, mut cmds: Vec<Command<S>>) -> Vec<Command<S>> {
        if cmds.iter().any(|c| matches!(c, Command::Retired)) {
            if let Some(r) = self.replicas.remove(name) {
                let t = self.tombs.entry(name.into()).or_default();
                t.promised = t.promised.max(r.promised());
                t.ended |= r.ended();
                self.tomb_since.insert(name.into(), now);
            }
        }
        let Some(before) = before else { return cmds };
        let after = self.fingerprint(name);
        if after != before {
            let disk = match (self.replicas.get(name), after.1) {
                (Some(r), _) => Disk::Replica(r.stored()),
                (None, Some(t)) => Disk::Tomb(t),
                (None, None) => Disk::Forget,
            };
            cmds.insert(0, Command::Persist(disk));
        }
        cmds
    }

    /// Forgets tombs older than [`TOMB_LIFETIME_S`], and the oldest beyond [`MAX_TOMBS`]; returns
    /// the names forgotten.
    fn prune_tombs(&mut self, now: Time) -> Vec<MissionName> {
        self.tomb_since.retain(|_, t| now - *t < TOMB_LIFETIME_S);
        if self.tomb_since.len() > MAX_TOMBS {
            let mut by_age: Vec<(Time, MissionName)> = self.tomb_since.iter().map(|(n, t)| (*t, n.clone())).collect();
            by_age.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (_, n) in by_age.into_iter().take(self.tomb_since.len() - MAX_TOMBS) {
                self.tomb_since.remove(&n);
            }
        }
        let keep = &self.tomb_since;
        let mut forgotten = Vec::new();
        self.tombs.retain(|n, _| {
            let k = keep.contains_key(n);
            if !k {
                forgotten.push(n.clone());
            }
            k
        });
        forgotten
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    type Reg = Registry<Vec<u32>>;

    fn p() -> Params {
        Params { quarantine: 0.0, ..Params::default() }
    }

    #[test]
    fn only_votes_and_updates_create_a_replica() {
        let mut r = Reg::new("b", p(), at(0.0));
        assert!(r.receive(at(0.0), "m", "a".into(), Msg::Ack { epoch: 1, seq: 1 }).is_empty());
        assert!(r.replica("m").is_none());
        let cfg = super::super::Config { epoch: 1, chain: vec!["a".into(), "b".into()] };
        let out = r.receive(at(0.0), "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        assert_eq!(out, vec![Command::Send { to: "a".into(), msg: Msg::Ack { epoch: 1, seq: 0 } }]);
        assert_eq!(r.replica("m").and_then(|x| x.state()), Some(&vec![1]));
    }

    #[test]
    fn an_ended_value_is_ended_again_for_stragglers_and_its_promise_kept() {
        let mut r = Reg::new("b", p(), at(0.0));
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into()] };
        r.receive(at(0.0), "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        let out = r.receive(at(0.1), "m", "a".into(), Msg::End { epoch: 3 });
        assert!(out.contains(&Command::Retired));
        assert!(r.replica("m").is_none());
        assert_eq!(r.tomb("m"), Some(Tomb { promised: 3, ended: true }));
        let vote = Msg::Vote { proposal: super::super::Config { epoch: 4, chain: vec!["c".into(), "b".into()] }, base: vec![], last: (3, 0) };
        assert_eq!(r.receive(at(0.2), "m", "c".into(), vote), vec![Command::Send { to: "c".into(), msg: Msg::End { epoch: u64::MAX } }]);
        assert!(r.replica("m").is_none(), "no replica for a straggler's vote");
    }

    #[test]
    fn tombs_are_forgotten_after_their_lifetime() {
        let mut r = Reg::new("b", p(), at(0.0));
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into()] };
        r.receive(at(0.0), "m", "a".into(), Msg::Update { config: cfg, seq: 0, state: vec![1] });
        r.receive(at(0.1), "m", "a".into(), Msg::End { epoch: 3 });
        r.tick(at(100.0));
        assert!(r.tomb("m").is_some(), "kept while stragglers may come");
        r.tick(at(0.1 + TOMB_LIFETIME_S));
        assert_eq!(r.tomb("m"), None);
    }

    /// Replays a durable registry's `Persist` commands onto a disk, as a driver writes them.
    fn write(disk: &mut BTreeMap<MissionName, Disk<Vec<u32>>>, name: &str, cmds: &[Command<Vec<u32>>]) {
        for c in cmds {
            if let Command::Persist(d) = c {
                match d {
                    Disk::Forget => disk.remove(name),
                    d => disk.insert(name.into(), d.clone()),
                };
            }
        }
    }

    /// A vote of a new chain with `b` in it, from a base `b` was not part of.
    fn vote(epoch: u64) -> Msg<Vec<u32>> {
        Msg::Vote {
            proposal: super::super::Config { epoch, chain: vec!["a".into(), "b".into(), "c".into()] },
            base: vec!["a".into(), "c".into()],
            last: (0, 0),
        }
    }

    #[test]
    fn a_durable_node_writes_before_it_grants_and_after_a_restart_never_votes_twice_in_an_epoch() {
        // Default parameters: a stateless node would wait out its 2 s quarantine.
        let mut disk = BTreeMap::new();
        let mut r = Reg::restore("b", Params::default(), at(0.0), at(0.0), disk.clone());
        let out = r.receive(at(0.1), "m", "a".into(), vote(5));
        assert!(matches!(&out[0], Command::Persist(Disk::Replica(s)) if s.promised == 5 && s.voted_for.as_ref().map(|x| x.as_str()) == Some("a")), "{out:?}");
        assert_eq!(out[1], Command::Send { to: "a".into(), msg: Msg::Grant { epoch: 5 } });
        write(&mut disk, "m", &out);
        // Crash, restart at once: the promise and the vote came back; another candidate of
        // epoch 5 is refused, the same one granted again (its grant may have been lost).
        let mut r = Reg::restore("b", Params::default(), at(0.2), at(0.2), disk.clone());
        let out = r.receive(at(0.2), "m", "c".into(), vote(5));
        assert!(matches!(out.last(), Some(Command::Send { msg: Msg::Refuse { promised: 5, .. }, .. })), "{out:?}");
        let out = r.receive(at(0.2), "m", "a".into(), vote(5));
        assert!(matches!(out.last(), Some(Command::Send { msg: Msg::Grant { epoch: 5 }, .. })), "{out:?}");
        // The stateless node refuses in its quarantine: what the disk replaces.
        let mut fresh = Reg::new("b", Params::default(), at(0.2));
        let out = fresh.receive(at(0.3), "m", "a".into(), vote(6));
        assert!(matches!(out.last(), Some(Command::Send { msg: Msg::Refuse { .. }, .. })), "{out:?}");
    }

    #[test]
    fn a_durable_node_keeps_what_it_acknowledged_and_counts_as_the_member_it_was() {
        let mut disk = BTreeMap::new();
        let mut r = Reg::restore("c", Params::default(), at(0.0), at(0.0), disk.clone());
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into(), "c".into()] };
        let out = r.receive(at(0.0), "m", "b".into(), Msg::Update { config: cfg, seq: 4, state: vec![1, 2] });
        assert!(matches!(&out[0], Command::Persist(Disk::Replica(s)) if s.state == Some(((3, 4), vec![1, 2]))), "{out:?}");
        assert_eq!(out.last(), Some(&Command::Send { to: "a".into(), msg: Msg::Ack { epoch: 3, seq: 4 } }));
        write(&mut disk, "m", &out);
        // A beat of the same state writes nothing.
        let cfg = super::super::Config { epoch: 3, chain: vec!["a".into(), "b".into(), "c".into()] };
        let out = r.receive(at(0.1), "m", "b".into(), Msg::Update { config: cfg, seq: 4, state: vec![1, 2] });
        assert!(!out.iter().any(|c| matches!(c, Command::Persist(_))), "{out:?}");
        // Restarted, it still holds (3, 4): a candidate with less is refused, and one of its
        // chain with as much is granted (a stateless restart would refuse it as lost).
        let mut r = Reg::restore("c", Params::default(), at(1.0), at(1.0), disk.clone());
        assert_eq!(r.replica("m").map(|x| x.version()), Some((3, 4)));
        let behind = Msg::Vote {
            proposal: super::super::Config { epoch: 4, chain: vec!["b".into(), "c".into()] },
            base: vec!["a".into(), "b".into(), "c".into()],
            last: (3, 2),
        };
        assert!(matches!(r.receive(at(1.0), "m", "b".into(), behind).last(), Some(Command::Send { msg: Msg::Refuse { .. }, .. })));
        let even = Msg::Vote {
            proposal: super::super::Config { epoch: 5, chain: vec!["b".into(), "c".into()] },
            base: vec!["a".into(), "b".into(), "c".into()],
            last: (3, 4),
        };
        assert!(matches!(r.receive(at(1.0), "m", "b".into(), even).last(), Some(Command::Send { msg: Msg::Grant { epoch: 5 }, .. })));
    }

    #[test]
    fn an_ending_durable_replica_comes_back_as_an_ended_tomb() {
        let mut disk = BTreeMap::new();
        let mut r = Reg::restore("a", Params::default(), at(0.0), at(0.0), disk.clone());
        let out = r.create(at(0.0), "m", vec!["b".into()], vec![1], 0);
        write(&mut disk, "m", &out);
        let out = r.handle(at(0.1), "m", Event::End);
        write(&mut disk, "m", &out);
        assert!(matches!(disk.get("m"), Some(Disk::Replica(s)) if s.ended), "{disk:?}");
        let mut r = Reg::restore("a", Params::default(), at(1.0), at(1.0), disk.clone());
        assert!(r.replica("m").is_none());
        assert_eq!(r.tomb("m"), Some(Tomb { promised: 1, ended: true }));
        assert!(matches!(r.receive(at(1.0), "m", "b".into(), vote(9)).as_slice(), [Command::Send { msg: Msg::End { .. }, .. }]));
    }
}
