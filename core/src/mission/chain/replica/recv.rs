//! What a replica does with each chain message it receives: votes, grants and refusals,
//! updates and acknowledgements, stale notices, ends and declines.

use mrmm_proto::chain::lineage_of;
use mrmm_proto::{NodeId, Time};

use super::{Command, Config, Msg, Replica, Role, Version};

impl<S: Clone> Replica<S> {
    pub(super) fn recv(&mut self, now: Time, from: NodeId, msg: Msg<S>) -> Vec<Command<S>> {
        match msg {
            Msg::Vote { proposal, base, last } => self.on_vote(now, from, proposal, &base, last),
            Msg::Grant { epoch } => {
                if let Role::Candidate { proposal, grants, .. } = &mut self.role {
                    if proposal.epoch == epoch {
                        grants.insert(from);
                        return self.check_win(now);
                    }
                }
                vec![]
            }
            Msg::Refuse { epoch, promised, last } => {
                let Role::Candidate { proposal, .. } = &self.role else { return vec![] };
                if proposal.epoch != epoch {
                    return vec![];
                }
                self.seen = self.seen.max(promised);
                if last > self.version() {
                    return self.outdone(now, last);
                }
                vec![]
            }
            Msg::Update { config, seq, state } => self.on_update(now, from, config, seq, Some(state)),
            Msg::Beat { config, seq } => self.on_update(now, from, config, seq, None),
            Msg::Behind { epoch } => self.on_behind(epoch),
            Msg::Ack { epoch, seq } => {
                let (e, mine) = self.version();
                if let Role::Head { committed, .. } = &mut self.role {
                    let seq = seq.min(mine);
                    if epoch == e && *committed < Some(seq) {
                        *committed = Some(seq);
                        return vec![Command::Committed { epoch, seq }];
                    }
                }
                vec![]
            }
            Msg::Stale { promised, last } => self.on_stale(now, promised, last),
            Msg::End { epoch } => self.on_end(epoch),
            Msg::EndAck { epoch } => match self.role {
                Role::Ending { epoch: e, .. } if e == epoch => self.retire(),
                _ => vec![],
            },
            Msg::Decline { epoch } => self.on_decline(now, from, epoch),
        }
    }

    /// A node of our chain will never acknowledge: without a new chain nothing would ever
    /// commit. Stand at once for one without it (safe as any election).
    fn on_decline(&mut self, now: Time, from: NodeId, epoch: u64) -> Vec<Command<S>> {
        let Some(config) = self.config.clone().filter(|c| c.epoch == epoch && c.contains(from.as_str())) else { return vec![] };
        if from == self.me || !matches!(self.role, Role::Head { .. }) || !self.declined.insert(from.clone()) {
            return vec![];
        }
        tracing::info!(node = %self.me, epoch, %from, "chain: a node declined to replicate; changing the chain without it");
        let chain = self.live_chain(&config, true);
        let next = self.next_epoch();
        self.stand(now, Config { epoch: next, chain }, true)
    }

    /// A node of our chain lost the state (it restarted): the head sends it down the chain again.
    fn on_behind(&self, epoch: u64) -> Vec<Command<S>> {
        if let (Role::Head { .. }, Some(config), Some(((e, seq), state))) = (&self.role, &self.config, &self.state) {
            if config.epoch == epoch && *e == epoch {
                if let Some(n) = config.next(self.me.as_str()) {
                    return vec![Command::Send { to: n.into(), msg: Msg::Update { config: config.clone(), seq: *seq, state: state.clone() } }];
                }
            }
        }
        vec![]
    }

    /// Someone promised a higher epoch than ours: outdone by a newer state, or, as head, lead again
    /// above it.
    fn on_stale(&mut self, now: Time, promised: u64, last: Version) -> Vec<Command<S>> {
        if !self.leads() {
            return vec![];
        }
        self.seen = self.seen.max(promised);
        if last > self.version() {
            return self.outdone(now, last);
        }
        if let (Role::Head { .. }, Some(config)) = (&self.role, self.config.clone()) {
            // Someone promised a higher epoch to a candidate that cannot hold a newer
            // state than ours: lead again above it.
            let epoch = self.next_epoch();
            let chain = config.chain.iter().filter(|n| **n == self.me || !self.gone.contains(*n)).cloned().collect();
            return self.stand(now, Config { epoch, chain }, true);
        }
        vec![]
    }

    /// The value ends: passed down the chain (the tail acknowledges to the head), and retired.
    fn on_end(&mut self, epoch: u64) -> Vec<Command<S>> {
        if epoch < self.config.as_ref().map_or(0, |c| c.epoch) {
            return vec![];
        }
        let mut out = Vec::new();
        self.ended = true;
        if let Some(c) = &self.config {
            match c.next(self.me.as_str()) {
                Some(n) => out.push(Command::Send { to: n.into(), msg: Msg::End { epoch } }),
                None => out.push(Command::Send { to: c.head().into(), msg: Msg::EndAck { epoch } }),
            }
        }
        out.extend(self.retire());
        out
    }

    fn on_vote(&mut self, now: Time, from: NodeId, proposal: Config, base: &[NodeId], last: Version) -> Vec<Command<S>> {
        let e = proposal.epoch;
        if let Role::Ending { epoch, .. } = self.role {
            // The value is being ended: a candidate that missed it ends too, rather than bring
            // it back — one of its lineage; a newer lineage (started anew without this chain)
            // is not this chain's to end.
            let msg = if lineage_of(e) <= lineage_of(epoch) {
                Msg::End { epoch: u64::MAX }
            } else {
                Msg::Refuse { epoch: e, promised: self.promised, last: self.version() }
            };
            return vec![Command::Send { to: from, msg }];
        }
        let epoch_ok = e > self.promised || (e == self.promised && self.voted_for.as_ref().map(|x| x.as_str()) == Some(from.as_str()));
        // A member of the candidate's chain that holds nothing lost its state (restart): its vote
        // must not count as that of the member who held it. Except for the head of a chain of
        // two, standing again: every change of a two-node chain needs both votes, so no newer
        // configuration can exist without this head, which holds the newest state — and a chain
        // of two would otherwise never recover from its one replica restarting.
        let head_of_two = base.len() == 2 && base.first() == Some(&from);
        let lost = self.state.is_none() && base.contains(&self.me) && !head_of_two;
        // A new chain keeps a majority of the current one, so a later candidate that missed this
        // change always meets a node that holds a newer state than its own.
        let keeps = 2 * base.iter().filter(|n| proposal.contains(n.as_str())).count() > base.len();
        let grant = epoch_ok && !lost && keeps && last >= self.version() && now - self.born >= self.p.quarantine;
        if !grant {
            return vec![Command::Send { to: from, msg: Msg::Refuse { epoch: e, promised: self.promised, last: self.version() } }];
        }
        if e > self.promised {
            self.promised = e;
            self.voted_for = Some(from.clone());
        }
        let mut out = self.step_down();
        self.last_heard = now;
        out.push(Command::Send { to: from, msg: Msg::Grant { epoch: e } });
        out
    }

    /// An update (`state`), or a beat (`None`: the head's state is still `(epoch, seq)`).
    fn on_update(&mut self, now: Time, _from: NodeId, config: Config, seq: u64, state: Option<S>) -> Vec<Command<S>> {
        let e = config.epoch;
        if e < self.promised {
            return vec![Command::Send { to: config.head().into(), msg: Msg::Stale { promised: self.promised, last: self.version() } }];
        }
        if config.head() == self.me {
            return vec![];
        }
        self.restored = false;
        // A head of a current chain is heard: whatever passed us over is known now.
        self.passed_over = 0;
        let mut out = Vec::new();
        if matches!(self.role, Role::Ending { .. }) {
            return out;
        }
        // A head of epoch `e ≥ promised` exists: whatever we stood for is over.
        out.extend(self.step_down());
        if e > self.promised {
            self.promised = e;
            self.voted_for = None;
        }
        if !config.contains(self.me.as_str()) {
            out.extend(self.retire());
            return out;
        }
        if self.config.as_ref().is_none_or(|c| c.epoch <= e) {
            self.config = Some(config.clone());
        }
        let beat = state.is_none();
        if let Some(state) = state.filter(|_| (e, seq) > self.version()) {
            self.state = Some(((e, seq), state));
        }
        self.last_heard = now;
        if beat && (self.state.is_none() || self.version() < (e, seq)) {
            // We lack what the whole chain was thought to hold.
            out.push(Command::Send { to: config.head().into(), msg: Msg::Behind { epoch: e } });
            return out;
        }
        let Some(((se, sseq), s)) = self.state.clone() else { return out };
        if se != e {
            return out;
        }
        match config.next(self.me.as_str()) {
            Some(n) if beat && sseq == seq => out.push(Command::Send { to: n.into(), msg: Msg::Beat { config: config.clone(), seq } }),
            Some(n) => out.push(Command::Send { to: n.into(), msg: Msg::Update { config: config.clone(), seq: sseq, state: s } }),
            None => out.push(Command::Send { to: config.head().into(), msg: Msg::Ack { epoch: e, seq: sseq } }),
        }
        out
    }
}
