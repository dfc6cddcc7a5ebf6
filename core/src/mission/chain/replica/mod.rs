//! One node's replica of one chain-replicated value: follower, candidate or head.

use std::collections::BTreeSet;

mod recv;

use mrmm_proto::chain::lineage_of;
use mrmm_proto::{NodeId, Time};

use super::{Command, Config, Event, Msg, Params, Stored, Version};

/// What a node is doing for the value.
#[derive(Debug, Clone, PartialEq)]
pub enum Role {
    Follower,
    /// Standing for `proposal.epoch`; `was_head` when the head is changing its own chain.
    Candidate {
        proposal: Config,
        grants: BTreeSet<NodeId>,
        since: Time,
        was_head: bool,
    },
    /// Leading `config`; `committed` is the highest seq of this epoch on every chain node.
    Head {
        committed: Option<u64>,
        last_sent: Time,
        last_change: Time,
    },
    /// Ending the value: waiting for the chain to forget it.
    Ending {
        epoch: u64,
        last_sent: Time,
        since: Time,
    },
}

/// One node's replica.
#[derive(Debug, Clone)]
pub struct Replica<S> {
    me: NodeId,
    p: Params,
    /// When this node (process) started: it does not vote during `p.quarantine`.
    born: Time,
    /// Highest epoch voted for or followed; never goes back.
    promised: u64,
    voted_for: Option<NodeId>,
    config: Option<Config>,
    state: Option<(Version, S)>,
    /// A state proposed while a chain change is being voted; replicated once it is won.
    queued: Option<S>,
    role: Role,
    alive: BTreeSet<NodeId>,
    gone: BTreeSet<NodeId>,
    pool: Vec<NodeId>,
    /// Last time a head was heard from.
    last_heard: Time,
    /// Highest promise others told us of.
    seen: u64,
    /// The value was ended (terminated), not just left.
    ended: bool,
    /// Brought back from disk: it was this chain's member before the restart, and if it was the
    /// head, it may stand again once its chain stays silent.
    restored: bool,
    /// Its node keeps it on disk: it never throws its state away while it is in the chain.
    durable: bool,
    /// Nodes that declined to replicate for this head (until their liveliness comes again).
    declined: BTreeSet<NodeId>,
    /// Times in a row this (durable) replica stood and learnt that a chain of a newer epoch
    /// exists, without hearing from a head since: each doubles its wait before standing again
    /// (up to [`PASSED_OVER_MAX`] doublings). A replica left out of a newer chain would otherwise
    /// stand, and write its promise to disk, every `silence` seconds until it hears that chain.
    passed_over: u32,
    /// While leading: the last time everything this node held was committed (or when it began
    /// to lead). See [`Replica::uncommitted_for`].
    settled_at: Time,
}

/// Doublings of a passed-over replica's wait before it stands again: at most 2⁴ × `silence`.
pub const PASSED_OVER_MAX: u32 = 4;

/// What [`Replica::stored`] covers, cheap to compare: a change means a write.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Fingerprint {
    promised: u64,
    voted_for: Option<NodeId>,
    config: Option<Config>,
    version: Option<Version>,
    ended: bool,
}

impl Fingerprint {
    /// What a replica just created with promise `promised` holds.
    pub(super) fn blank(promised: u64) -> Fingerprint {
        Fingerprint { promised, voted_for: None, config: None, version: None, ended: false }
    }
}

impl<S: Clone> Replica<S> {
    /// A replica on node `me`, started at `born`, that already promised `promised` (from a
    /// previous replica of the same value on this node).
    pub fn new(me: &str, p: Params, born: Time, now: Time, promised: u64) -> Self {
        Replica {
            me: me.into(),
            p,
            born,
            promised,
            voted_for: None,
            config: None,
            state: None,
            queued: None,
            role: Role::Follower,
            alive: BTreeSet::new(),
            gone: BTreeSet::new(),
            pool: Vec::new(),
            last_heard: now,
            seen: 0,
            ended: false,
            restored: false,
            durable: false,
            declined: BTreeSet::new(),
            passed_over: 0,
            settled_at: now,
        }
    }

    /// Marks the replica as kept on disk by its node (see [`Replica::outdone`]).
    pub fn durable(mut self) -> Self {
        self.durable = true;
        self
    }

    /// The replica this node stored before it restarted: a follower, as it was.
    pub fn restore(me: &str, p: Params, born: Time, now: Time, stored: Stored<S>) -> Self {
        let mut r = Replica::new(me, p, born, now, stored.promised);
        r.voted_for = stored.voted_for;
        r.config = stored.config;
        r.state = stored.state;
        r.restored = true;
        r.durable = true;
        r
    }

    /// What must survive a restart.
    pub fn stored(&self) -> Stored<S> {
        Stored { promised: self.promised, voted_for: self.voted_for.clone(), config: self.config.clone(), state: self.state.clone(), ended: self.ended }
    }

    pub(super) fn fingerprint(&self) -> Fingerprint {
        Fingerprint {
            promised: self.promised,
            voted_for: self.voted_for.clone(),
            config: self.config.clone(),
            version: self.state.as_ref().map(|(v, _)| *v),
            ended: self.ended,
        }
    }

    pub fn role(&self) -> &Role {
        &self.role
    }
    pub fn is_head(&self) -> bool {
        matches!(self.role, Role::Head { .. })
    }
    /// Whether this node leads or is changing the chain it leads.
    pub fn leads(&self) -> bool {
        matches!(self.role, Role::Head { .. } | Role::Candidate { was_head: true, .. })
    }
    pub fn config(&self) -> Option<&Config> {
        self.config.as_ref()
    }
    pub fn state(&self) -> Option<&S> {
        self.state.as_ref().map(|(_, s)| s)
    }
    pub fn version(&self) -> Version {
        self.state.as_ref().map_or((0, 0), |(v, _)| *v)
    }
    pub fn promised(&self) -> u64 {
        self.promised
    }
    /// Times in a row this replica learnt, standing, that a newer chain exists (see
    /// [`PASSED_OVER_MAX`]).
    pub fn passed_over(&self) -> u32 {
        self.passed_over
    }
    /// Whether the value was ended (rather than this node leaving its chain).
    pub fn ended(&self) -> bool {
        self.ended
    }
    /// The highest committed seq of the current epoch, when leading.
    pub fn committed(&self) -> Option<u64> {
        match self.role {
            Role::Head { committed, .. } => committed,
            _ => None,
        }
    }

    /// Seconds this node has led the value without being able to commit: a change it holds is
    /// not on every node of its chain yet, or it is changing its chain. `None` when it does not
    /// lead, or everything it holds is committed. A chain that lost the memory of a majority of
    /// its nodes (restarted without disks) never commits again: its head says so here, and
    /// the system manager starts the value anew.
    pub fn uncommitted_for(&self, now: Time) -> Option<f64> {
        match &self.role {
            Role::Head { committed, .. } if *committed == Some(self.version().1) && self.queued.is_none() => None,
            Role::Head { .. } | Role::Candidate { was_head: true, .. } => Some((now - self.settled_at).max(0.0)),
            _ => None,
        }
    }

    /// Handles one event at time `now` (seconds).
    pub fn handle(&mut self, now: Time, ev: Event<S>) -> Vec<Command<S>> {
        if self.uncommitted_for(now).is_none() {
            self.settled_at = now;
        }
        let out = self.step(now, ev);
        if self.uncommitted_for(now).is_none() {
            self.settled_at = now;
        }
        out
    }

    fn step(&mut self, now: Time, ev: Event<S>) -> Vec<Command<S>> {
        match ev {
            Event::Tick => self.tick(now),
            Event::Recv { from, msg } => self.recv(now, from, msg),
            Event::Alive(n) => {
                self.gone.remove(&n);
                self.declined.remove(&n);
                self.alive.insert(n);
                vec![]
            }
            Event::Gone(n) => {
                self.alive.remove(&n);
                self.gone.insert(n);
                self.tick(now)
            }
            Event::Create { replicas, state, floor } => {
                let mut chain = vec![self.me.clone()];
                for r in replicas {
                    if !chain.contains(&r) {
                        chain.push(r);
                    }
                }
                // The first configuration needs no vote: nobody else can create this value. A
                // node that remembers a higher promise answers `Stale` and we re-elect above it.
                let epoch = self.promised.max(self.seen).saturating_add(1).max(floor);
                self.promised = epoch;
                self.voted_for = Some(self.me.clone());
                let config = Config { epoch, chain };
                self.config = Some(config.clone());
                self.state = Some(((epoch, 0), state.clone()));
                self.role = Role::Head { committed: None, last_sent: Time::LONG_AGO, last_change: now };
                let mut out = vec![Command::Lead { config, state }];
                out.extend(self.tick(now));
                out
            }
            Event::Propose(s) => match &mut self.role {
                Role::Head { .. } => {
                    let (e, seq) = self.version();
                    self.state = Some(((e, seq.saturating_add(1)), s));
                    if let Role::Head { last_sent, .. } = &mut self.role {
                        *last_sent = Time::LONG_AGO;
                    }
                    self.tick(now)
                }
                Role::Candidate { was_head: true, .. } => {
                    self.queued = Some(s);
                    vec![]
                }
                _ => vec![],
            },
            Event::Pool { nodes, k } => {
                self.pool = nodes;
                self.p.k = k;
                vec![]
            }
            Event::End => {
                if !self.leads() {
                    return vec![];
                }
                let epoch = self.promised;
                self.ended = true;
                self.role = Role::Ending { epoch, last_sent: Time::LONG_AGO, since: now };
                self.tick(now)
            }
        }
    }

    fn tick(&mut self, now: Time) -> Vec<Command<S>> {
        match self.role.clone() {
            Role::Head { committed, last_sent, last_change } => self.head_tick(now, committed, last_sent, last_change),
            Role::Candidate { since, ref proposal, .. } if now - since > self.vote_timeout(proposal.epoch) => self.retry(now),
            Role::Candidate { .. } => vec![],
            Role::Follower => self.maybe_stand(now),
            Role::Ending { epoch, last_sent, since } => {
                let next = self.config.as_ref().and_then(|c| c.next(self.me.as_str())).map(NodeId::from);
                match next {
                    Some(_) if now - since > 4.0 * self.p.silence => self.retire(),
                    Some(n) if now - last_sent >= self.p.beat => {
                        self.role = Role::Ending { epoch, last_sent: now, since };
                        vec![Command::Send { to: n, msg: Msg::End { epoch } }]
                    }
                    Some(_) => vec![],
                    None => self.retire(),
                }
            }
        }
    }

    fn head_tick(&mut self, now: Time, committed: Option<u64>, last_sent: Time, last_change: Time) -> Vec<Command<S>> {
        let Some(config) = self.config.clone() else { return vec![] };
        let Some(((e, seq), state)) = self.state.clone() else { return vec![] };
        let mut out = Vec::new();
        if now - last_sent >= self.p.beat {
            match config.next(self.me.as_str()) {
                // Once the whole chain holds the state, beats go without it.
                Some(n) if committed == Some(seq) => out.push(Command::Send { to: n.into(), msg: Msg::Beat { config: config.clone(), seq } }),
                Some(n) => out.push(Command::Send { to: n.into(), msg: Msg::Update { config: config.clone(), seq, state } }),
                None if committed < Some(seq) => {
                    // Alone in the chain: on every node already.
                    self.role = Role::Head { committed: Some(seq), last_sent: now, last_change };
                    out.push(Command::Committed { epoch: e, seq });
                    return out;
                }
                None => {}
            }
            self.role = Role::Head { committed, last_sent: now, last_change };
        }
        // Repair: once this epoch's chain holds our state, replace lost nodes and fill up to k.
        if committed.is_some() && now - last_change >= self.p.vote_timeout {
            let chain = self.live_chain(&config, true);
            if chain != config.chain {
                let epoch = self.next_epoch();
                out.extend(self.stand(now, Config { epoch, chain }, true));
            }
        }
        out
    }

    /// How long to wait for votes before trying the next epoch: longer further down the chain,
    /// plus a jitter drawn from (node, epoch), so two candidates do not split votes forever.
    fn vote_timeout(&self, epoch: u64) -> f64 {
        let pos = self.config.as_ref().and_then(|c| c.chain.iter().position(|n| *n == self.me)).unwrap_or(0);
        let mut h: u64 = 0xcbf2_9ce4_8422_2325 ^ epoch.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        for b in self.me.as_str().bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
        let jitter = (h >> 11) as f64 / (1u64 << 53) as f64;
        self.p.vote_timeout * (1.0 + 0.5 * pos as f64 + jitter)
    }

    fn next_epoch(&self) -> u64 {
        self.promised.max(self.seen).max(self.config.as_ref().map_or(0, |c| c.epoch)).saturating_add(1)
    }

    /// A follower of a chain stands when the head is gone and every node before it too, or when
    /// no head was heard from for `silence` times its position.
    fn maybe_stand(&mut self, now: Time) -> Vec<Command<S>> {
        let Some(config) = self.config.clone() else { return vec![] };
        let Some(pos) = config.chain.iter().position(|n| *n == self.me) else { return vec![] };
        if self.state.is_none() {
            return vec![];
        }
        // A head that lost its lead follows its successors; one restored from disk stands again
        // after the others had their turn.
        let wait = match pos {
            0 if self.restored => config.chain.len(),
            0 => return vec![],
            _ => pos,
        };
        let before_gone = pos > 0 && config.chain[..pos].iter().all(|n| self.gone.contains(n));
        let backoff = f64::from(1u32 << self.passed_over.min(PASSED_OVER_MAX));
        let silent = now - self.last_heard > self.p.silence * wait as f64 * backoff;
        if !before_gone && !silent {
            return vec![];
        }
        let chain = self.live_chain(&config, false);
        let epoch = self.next_epoch();
        self.stand(now, Config { epoch, chain }, false)
    }

    /// This node first, then the nodes of `base` not known to be gone, then (for a head) live
    /// nodes of the pool, up to `k + 1`.
    fn live_chain(&self, base: &Config, from_pool: bool) -> Vec<NodeId> {
        let mut chain = vec![self.me.clone()];
        chain.extend(base.chain.iter().filter(|n| **n != self.me && !self.gone.contains(*n) && !self.declined.contains(*n)).cloned());
        if from_pool {
            for n in &self.pool {
                if chain.len() > self.p.k {
                    break;
                }
                if self.alive.contains(n) && !chain.contains(n) && !self.declined.contains(n) {
                    chain.push(n.clone());
                }
            }
        }
        chain.truncate((self.p.k + 1).max(chain.len().min(base.chain.len())));
        chain
    }

    /// Tries again with the next epoch, with the nodes that are alive now.
    fn retry(&mut self, now: Time) -> Vec<Command<S>> {
        let Role::Candidate { proposal, was_head, .. } = self.role.clone() else { return vec![] };
        let base = self.config.clone().unwrap_or(proposal);
        let chain = self.live_chain(&base, was_head);
        let epoch = self.next_epoch();
        let out = self.stand(now, Config { epoch, chain }, was_head);
        if out.is_empty() {
            // Not enough of the chain alive to stand: keep waiting as a candidate.
            if let Role::Candidate { since, .. } = &mut self.role {
                *since = now;
            }
        }
        out
    }

    fn stand(&mut self, now: Time, proposal: Config, was_head: bool) -> Vec<Command<S>> {
        // A state never crosses into a newer lineage: a replica that learnt of a promise of one
        // (the value was started anew without this chain) would otherwise stand above it with
        // the old lineage's state, and win against the new one (system sim seed 1473).
        if self.state.as_ref().is_some_and(|((e, _), _)| lineage_of(proposal.epoch) > lineage_of(*e)) {
            tracing::info!(node = %self.me, epoch = proposal.epoch, "chain: a newer lineage of this value exists; retiring");
            return self.retire();
        }
        let base = self.config.clone().unwrap_or_else(|| proposal.clone());
        if !base.majority(|n| proposal.contains(n)) {
            // Too few of the current chain left to carry its commits into a new one: wait.
            return vec![];
        }
        self.promised = proposal.epoch;
        self.voted_for = Some(self.me.clone());
        let last = self.version();
        tracing::debug!(node = %self.me, epoch = proposal.epoch, chain = ?proposal.chain, was_head, "chain: standing");
        let mut to: BTreeSet<&NodeId> = base.chain.iter().collect();
        to.extend(proposal.chain.iter());
        let mut out: Vec<Command<S>> = to
            .into_iter()
            .filter(|n| **n != self.me)
            .map(|n| Command::Send { to: n.clone(), msg: Msg::Vote { proposal: proposal.clone(), base: base.chain.clone(), last } })
            .collect();
        let grants = BTreeSet::from([self.me.clone()]);
        self.role = Role::Candidate { proposal, grants, since: now, was_head };
        out.extend(self.check_win(now));
        out
    }

    fn check_win(&mut self, now: Time) -> Vec<Command<S>> {
        let Role::Candidate { proposal, grants, was_head, .. } = &self.role else { return vec![] };
        let base = self.config.as_ref().unwrap_or(proposal);
        if !(base.majority(|n| grants.contains(n)) && proposal.majority(|n| grants.contains(n))) {
            return vec![];
        }
        let (config, was_head) = (proposal.clone(), *was_head);
        tracing::info!(node = %self.me, epoch = config.epoch, chain = ?config.chain, "chain: leading");
        let Some((_, state)) = self.state.take() else { return vec![] };
        let state = self.queued.take().unwrap_or(state);
        self.config = Some(config.clone());
        self.state = Some(((config.epoch, 0), state.clone()));
        self.role = Role::Head { committed: None, last_sent: Time::LONG_AGO, last_change: now };
        let mut out = Vec::new();
        if !was_head {
            out.push(Command::Lead { config, state });
        }
        out.extend(self.tick(now));
        out
    }

    fn step_down(&mut self) -> Vec<Command<S>> {
        let leading = self.leads();
        if !matches!(self.role, Role::Follower) {
            tracing::info!(node = %self.me, promised = self.promised, "chain: following");
        }
        self.role = Role::Follower;
        self.queued = None;
        if leading {
            vec![Command::StepDown]
        } else {
            vec![]
        }
    }

    /// Someone holds a newer state (`last`) than ours: we must not lead. If it is of a newer
    /// epoch, our configuration is outdated and our state must not count in its votes: retire.
    /// If it is of our epoch, we are still a member of the current chain (its head may need our
    /// vote): follow, keep the state, and give the head time to be heard. A durable replica
    /// always keeps its state and follows: retiring would write it off for good, and a newer
    /// chain it is part of, whose head crashed before reaching it, would then miss a member
    /// holding state (found by the chain simulation with power cycles); the up-to-date rule
    /// keeps its older state from winning. Except for a newer *lineage*: the value was started
    /// anew without this chain's state, which no chain of the new lineage can ever need.
    fn outdone(&mut self, now: Time, last: Version) -> Vec<Command<S>> {
        let mine = self.config.as_ref().map_or(0, |c| c.epoch);
        let newer_chain = last.0 > mine;
        let newer_lineage = lineage_of(last.0) > lineage_of(mine);
        if newer_chain && (!self.durable || newer_lineage) {
            return self.retire();
        }
        if newer_chain {
            self.passed_over = self.passed_over.saturating_add(1);
        }
        self.last_heard = now;
        self.step_down()
    }

    /// Out of the chain for good: forget the value (the promise stays with the caller).
    fn retire(&mut self) -> Vec<Command<S>> {
        let mut out = self.step_down();
        self.config = None;
        self.state = None;
        out.push(Command::Retired);
        out
    }
}
