//! Faults: when they come, crashes, and the liveliness tokens the nodes see (or stop seeing).

use super::*;

impl World {
    pub(super) fn schedule_faults(&mut self) {
        let d = self.cfg.duration;
        let first = |every: f64, rng: &mut ChaCha8Rng| (every > 0.0).then(|| rng.gen_range(0.2 * every..1.8 * every)).filter(|t| *t < d);
        if let Some(t) = first(self.cfg.crash_every, &mut self.rng) {
            self.queue.push(Time::from_secs(t + 2.0), Ev::Crash);
        }
        if let Some(t) = first(self.cfg.partition_every, &mut self.rng) {
            self.queue.push(Time::from_secs(t + 2.0), Ev::Partition);
        }
        if let Some(t) = first(self.cfg.suspect_every, &mut self.rng) {
            self.queue.push(Time::from_secs(t + 2.0), Ev::Suspect);
        }
    }

    pub(super) fn next_fault(&mut self, every: f64, ev: Ev) {
        let at = self.now + self.rng.gen_range(0.2 * every..1.8 * every);
        if at < self.end() {
            self.queue.push(at, ev);
        }
    }

    /// A random node crashes (central only if the run allows it), and comes back if it restarts.
    pub(super) fn random_crash(&mut self) {
        self.next_fault(self.cfg.crash_every, Ev::Crash);
        if !self.links.up.iter().all(|u| *u) {
            return;
        }
        let candidates: Vec<usize> = (0..self.nodes.len()).filter(|i| self.nodes[*i].kind != Kind::Central || self.cfg.crash_central).collect();
        if candidates.is_empty() {
            return;
        }
        let i = candidates[self.rng.gen_range(0..candidates.len())];
        self.crash(i);
        if self.cfg.restart {
            let back = self.now + self.rng.gen_range(0.5..4.0);
            self.queue.push(back, Ev::Restart(i));
        }
    }

    /// Node `i` starts again: a new incarnation, with what it had on disk.
    pub(super) fn restart(&mut self, i: usize) {
        self.links.up[i] = true;
        self.links.inc[i] += 1;
        let name = self.nodes[i].name.clone();
        self.log(|| format!("restart {name}"));
        self.beliefs.forget(i, |_| false);
        self.boot(i);
    }

    /// The network splits in two random sides until it heals (and, in some runs, central's side
    /// is power-cycled meanwhile).
    pub(super) fn random_partition(&mut self) {
        self.next_fault(self.cfg.partition_every, Ev::Partition);
        if self.links.partitioned() {
            return;
        }
        let side: Vec<bool> = (0..self.nodes.len()).map(|_| self.rng.gen_bool(0.5)).collect();
        self.log(|| format!("partition {side:?}"));
        self.links.partition(side);
        self.report.partitions += 1;
        let mut heal = (self.now + self.rng.gen_range(0.5..6.0)).min(self.end());
        if self.cfg.side_cycles && self.fault_rng.gen_bool(0.3) {
            // Long enough for central, back, to start anew what it cannot see.
            self.queue.push(self.now + self.fault_rng.gen_range(0.3..1.0), Ev::CycleSide);
            heal = heal.max((self.now + self.fault_rng.gen_range(9.0..15.0)).min(self.end()));
        }
        self.queue.push(heal, Ev::Heal);
        self.liveliness(self.cfg.lease);
    }

    /// One node falsely loses another for a while.
    pub(super) fn random_suspicion(&mut self) {
        self.next_fault(self.cfg.suspect_every, Ev::Suspect);
        let n = self.nodes.len();
        let (a, b) = (self.rng.gen_range(0..n), self.rng.gen_range(0..n));
        if a == b {
            return;
        }
        self.log(|| format!("n{a} falsely loses n{b}"));
        self.report.suspicions += 1;
        self.links.suspect(a, b, true);
        let until = (self.now + self.rng.gen_range(1.5..5.0)).min(self.end());
        self.queue.push(until, Ev::Unsuspect(a, b));
        self.liveliness(self.cfg.lease);
    }

    pub(super) fn crash(&mut self, i: usize) {
        let name = self.nodes[i].name.clone();
        self.log(|| format!("crash {name}"));
        self.report.crashes += 1;
        self.links.up[i] = false;
        let n = &mut self.nodes[i];
        if let (Some(r), Some(c)) = (&n.robot, &mut n.cfg) {
            // The body stays where it is: the restarted process starts from there.
            c.start = r.pose();
        }
        n.central = None;
        n.host = None;
        n.robot = None;
        n.served.clear();
        n.links = robot::Links::new(&n.name);
        self.inv.gone(i);
        self.liveliness(0.02);
    }

    /// Every node on central's side of the partition goes down at once; central comes back
    /// first, the others after it (so central counts them as started after it went down).
    pub(super) fn cycle_side(&mut self) {
        let Some(c) = self.nodes.iter().position(|n| n.kind == Kind::Central) else { return };
        if !self.links.partitioned() || !self.links.up[c] {
            return;
        }
        let side = self.links.side_of(c);
        let nodes: Vec<usize> = (0..self.nodes.len()).filter(|i| self.links.up[*i] && self.links.side_of(*i) == side).collect();
        self.log(|| format!("power cycle of central's side: {nodes:?}"));
        for &i in &nodes {
            self.crash(i);
            let back = if i == c { self.fault_rng.gen_range(0.5..1.0) } else { self.fault_rng.gen_range(1.5..4.0) };
            self.queue.push(self.now + back, Ev::Restart(i));
        }
    }

    /// Every token present now, with its holder.
    pub(super) fn tokens(&self) -> Vec<(Token, usize)> {
        let mut out = Vec::new();
        for (i, n) in self.nodes.iter().enumerate() {
            if !self.links.up[i] {
                continue;
            }
            if n.host.is_some() {
                out.push((Token::Host(n.name.clone()), i));
            }
            match n.kind {
                Kind::Central => out.push((Token::Planner, i)),
                Kind::Robot => {
                    out.push((Token::Robot(n.name.clone()), i));
                    if let Some(t) = n.links.team() {
                        out.push((Token::Member { subteam: t.subteam.clone(), robot: n.name.clone() }, i));
                    }
                }
                Kind::Host => {}
            }
        }
        out
    }

    /// Tells every observer what changed in what it watches, `delay` from now.
    pub(super) fn liveliness(&mut self, delay: f64) {
        let tokens = self.tokens();
        // Each robot watches the members of the widest team its plan has barriers with.
        let teams: Vec<Option<String>> = self.nodes.iter().map(|n| n.links.team().map(|t| t.widest().to_string())).collect();
        let kinds: Vec<(bool, bool)> = self.nodes.iter().map(|n| (n.central.is_some() || n.host.is_some(), n.robot.is_some())).collect();
        let watches = |o: usize, t: &Token| match t {
            Token::Member { subteam, .. } => kinds[o].1 && teams[o].as_ref().is_some_and(|team| mrmm_proto::team_within(subteam, team)),
            _ => kinds[o].0,
        };
        for c in self.beliefs.update(self.now, delay, &self.links, &tokens, watches) {
            let inc = self.links.inc[c.observer];
            self.queue.push(c.at, Ev::Live(c, inc));
        }
    }

    /// A liveliness change reaches the machines of `node` that watch it; its system manager and
    /// mission host, if they `missed` it (`Config::missed_live`), learn it from their roll calls
    /// only.
    pub(super) fn tell(&mut self, node: usize, token: &Token, up: bool, missed: bool) -> Result<(), String> {
        let missed = missed && !matches!(token, Token::Member { .. });
        if !matches!(token, Token::Member { .. }) {
            let name = self.nodes[node].name.clone();
            let how = if missed { "misses" } else { "sees" };
            self.log(|| format!("{name} {how} {token:?} {}", if up { "up" } else { "gone" }));
        }
        let keys: Vec<mrmm_proto::Key> = match token {
            Token::Robot(id) => vec![mrmm_proto::Key::RobotAlive(id.clone().into())],
            Token::Host(name) => vec![mrmm_proto::Key::HostAlive(name.clone().into())],
            Token::Planner => {
                ["patrol", "coverage"].map(|kind| mrmm_proto::Key::PlannerAlive { kind: kind.to_string(), zid: CENTRAL_HOST.to_string() }).to_vec()
            }
            Token::Member { .. } => vec![],
        };
        for key in keys {
            if !missed && !matches!(token, Token::Planner) {
                self.central_hears(node, Wire::token(key.clone(), up))?;
            }
            // A robot follows central's host token (not a machine with a roll call).
            if matches!(token, Token::Host(name) if name == CENTRAL_HOST) {
                self.robot_hears(node, Wire::token(key.clone(), up))?;
            }
            if !missed {
                self.host_hears(node, Wire::token(key, up))?;
            }
        }
        match token {
            Token::Robot(_) | Token::Host(_) | Token::Planner => Ok(()),
            Token::Member { subteam, robot } => {
                self.robot_hears(node, Wire::token(mrmm_proto::Key::TeamMember { subteam: subteam.clone(), robot: robot.clone().into() }, up))
            }
        }
    }
}
