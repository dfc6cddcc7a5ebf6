//! The production machines on their nodes: central, mission hosts and robots, and what their commands do in the world.

use mrmm_core::machine::{Effect, Machine};
use mrmm_core::robot::Robot;

use super::driver;
use super::*;

impl World {
    pub(super) fn central(&mut self, i: usize, ev: central::Event) -> Result<(), String> {
        let now = self.now;
        let Some(c) = self.nodes[i].central.as_mut() else {
            return Ok(());
        };
        let cmds = c.handle(now, ev);
        // Carried out by the production driver's step, over the simulation's runtime.
        let journaled = cmds.iter().any(|c| CentralCore::effect(c) == Effect::Persist);
        driver::carry_out::<CentralCore>(self, i, cmds)?;
        if let (true, Some(c)) = (journaled, self.nodes[i].central.as_ref()) {
            let want = c.system().durable();
            if self.nodes[i].disk != want {
                return Err(format!("central's journal replays to {:?}, but central holds {want:?}", self.nodes[i].disk));
            }
        }
        Ok(())
    }

    /// One command of central's, carried out as its driver does (its journal is written by
    /// the driver before this).
    pub(super) fn central_command(&mut self, i: usize, cmd: central::Command) -> Result<(), String> {
        // What it publishes goes out as the driver puts it on the network.
        if let Some(out) = central::egress(&cmd) {
            self.publish(i, out);
        }
        match cmd {
            central::Command::Publish(_) | central::Command::Traffic(_) => Ok(()),
            central::Command::System(s) => self.system_command(i, s),
        }
    }

    pub(super) fn system_command(&mut self, i: usize, c: system::Command) -> Result<(), String> {
        match &c {
            system::Command::SendToRobot { robot, cmd, .. } => {
                let line = format!("central -> {robot}: {cmd:?}").chars().take(160).collect::<String>();
                self.log(|| line);
            }
            system::Command::Ctl { id, mission, ctl, .. } => {
                let line = format!("central ctl {id} {mission}: {ctl:?}").chars().take(160).collect::<String>();
                self.log(|| line);
            }
            _ => {}
        }
        if let system::Command::StartMission { start, .. } = &c {
            let mission = &start.spec.name;
            if start.anew {
                self.report.anew += 1;
                let assigned = self.nodes[i].central.as_ref().map_or(0, |c| c.system().durable().assignment.values().filter(|m| *m == mission).count());
                if start.members.len() < assigned {
                    self.report.anew_short += 1;
                }
            }
        }
        // A question goes to whoever serves its key, as the driver asks it.
        if let Some(ask) = system::asks::ask(&c) {
            return self.ask_key(Some(i), &ask.key, ask.payload.as_deref(), ask.timeout_s, Ctx::Central(ask.then));
        }
        match c {
            system::Command::FetchInfo { .. }
            | system::Command::SendToRobot { .. }
            | system::Command::StartMission { .. }
            | system::Command::Ctl { .. }
            | system::Command::Forward { .. } => {}
            system::Command::Refused(r) => return Err(format!("central refused: {r} (no node of the simulation is a rogue)")),
            system::Command::Chain { to, envelope } => {
                self.report.fenced += 1;
                // Published by `central` with the other publications.
                self.log(|| format!("central -> {to}: {} {}", envelope.mission, envelope.msg.describe()));
            }
            system::Command::Journal(entries) => {
                // Committed before anything else of this event happens (the driver's order,
                // checked by the simulation's runtime, `driver.rs`); what is on the disk must be exactly what
                // central holds.
                let disk = &mut self.nodes[i].disk;
                for e in &entries {
                    disk.apply(e);
                }
                for e in entries.iter().filter(|e| matches!(e, mrmm_proto::JournalEvent::RobotReleasing { .. } | mrmm_proto::JournalEvent::RobotLetGo { .. })) {
                    self.log(|| format!("journal: {e:?}"));
                }
            }
            system::Command::RollCall => {
                // Central's liveliness queries, answered from what its Zenoh tables hold, a little later.
                let (inc, present) = (self.links.inc[i], self.present(i));
                self.queue.push(self.now + 0.01, Ev::LocalCentral { node: i, inc, ev: Box::new(central::Event::System(system::Event::RollCall(Ok(present)))) });
            }
            system::Command::DryRun(dry) => {
                // Off central's loop in the driver: here, answered a little later.
                let result = dry.run();
                let at = self.now + self.rng.gen_range(0.001..0.05);
                let inc = self.links.inc[i];
                self.queue.push(at, Ev::LocalCentral { node: i, inc, ev: Box::new(central::Event::System(system::Event::DryRunDone { id: dry.id, result })) });
            }
            system::Command::Reply { req: Req::Query(q), result } => {
                let short = result.as_ref().map(|_| "ok".to_string()).unwrap_or_else(|e| e.error.clone());
                self.log(|| format!("operator request {q}: {short}"));
                self.op.answered(q, result.is_ok())
            }
            system::Command::Reply { req: Req::Agent(_), .. } => return Err("an answer to the agent left central".into()),
        }
        Ok(())
    }

    /// The answer to node `i`'s roll call: the tokens its Zenoh tables hold up (of robots, hosts
    /// and planners; team members are not called).
    fn present(&self, i: usize) -> mrmm_core::roll_call::Present {
        let mut present = mrmm_core::roll_call::Present::default();
        for t in self.beliefs.up_for(i) {
            match t {
                Token::Robot(id) => present.take(&mrmm_proto::Key::RobotAlive(id.clone().into()).to_string()),
                Token::Host(name) => present.take(&mrmm_proto::Key::HostAlive(name.clone().into()).to_string()),
                Token::Planner => {
                    for kind in ["patrol", "coverage"] {
                        present.take(&mrmm_proto::Key::PlannerAlive { kind: kind.into(), zid: CENTRAL_HOST.into() }.to_string());
                    }
                }
                Token::Member { .. } => {}
            }
        }
        present
    }

    pub(super) fn host(&mut self, i: usize, ev: host::Event) -> Result<(), String> {
        let now = self.now;
        let Some(h) = self.nodes[i].host.as_mut() else {
            return Ok(());
        };
        let cmds = h.handle(now, ev);
        // Carried out by the production driver's step, over the simulation's runtime.
        driver::carry_out::<HostCore>(self, i, cmds)?;
        if let Some(h) = self.nodes[i].host.as_ref() {
            self.inv.host(i, self.links.inc[i], h)?;
        }
        self.one_mission_per_robot()
    }

    /// One command of a host's, carried out as its driver does.
    pub(super) fn host_effect(&mut self, i: usize, c: host::Command) -> Result<(), String> {
        if let Some(out) = host::egress(&c) {
            self.publish(i, out);
        }
        if let Some(ask) = host::asks::ask(&c) {
            self.ask_key(Some(i), &ask.key, ask.payload.as_deref(), ask.timeout_s, Ctx::Host(ask.then))?;
        }
        self.host_command(i, c)
    }

    /// Invariant 3, over missions that have a head and are neither terminated by the operator
    /// nor unrecoverable (their chain lost a majority of its memory: they can never commit, so
    /// never act, again).
    pub(super) fn one_mission_per_robot(&self) -> Result<(), String> {
        for (r, a, b) in self.inv.in_two_missions() {
            let led = |m: &str| self.nodes.iter().any(|n| n.host.as_ref().is_some_and(|h| h.heads().any(|(x, _)| x == m)));
            let counts = |m: &str| !self.op.terminated.contains(m) && led(m) && self.recoverable(m);
            if counts(a.as_str()) && counts(b.as_str()) {
                return Err(format!("robot {r} is a member of {a} and of {b}"));
            }
        }
        Ok(())
    }

    pub(super) fn host_command(&mut self, i: usize, c: host::Command) -> Result<(), String> {
        if self.trace.is_some() {
            let name = self.nodes[i].name.clone();
            let line = match &c {
                host::Command::Chain { to, envelope } => Some(format!("{name} -> {to}: {} {}", envelope.mission, envelope.msg.describe())),
                host::Command::Status(_) => None,
                host::Command::SendPlan { mission, robot, assignment } => Some(format!("{name}: plan of {mission} epoch {} to {robot}", assignment.epoch)),
                host::Command::RequestPlan { mission, epoch, local, .. } => Some(format!("{name}: plan {mission} epoch {epoch} (local {local})")),
                other => Some(format!("{name}: {other:?}")),
            };
            if let Some(l) = line {
                self.log(|| l);
            }
        }
        match c {
            host::Command::RollCall => {
                // The host's liveliness queries, as central's.
                let (inc, present) = (self.links.inc[i], self.present(i));
                self.queue.push(self.now + 0.01, Ev::Local { node: i, inc, ev: Box::new(host::Event::RollCall(Ok(present))) });
            }
            host::Command::Persist { mission, disk } => {
                if !self.nodes[i].kind.keeps_chain_state(self.cfg.disks) {
                    return Err(format!("{} has no disk but was asked to persist {mission}", self.nodes[i].name));
                }
                match *disk {
                    mrmm_core::mission::chain::Disk::Forget => self.nodes[i].chain_disk.remove(&mission),
                    d => self.nodes[i].chain_disk.insert(mission, d),
                };
            }
            // Published by `host`.
            host::Command::Chain { .. } | host::Command::Status(_) => {}
            host::Command::Reply { query, result } => {
                if let (Ok(_), Some(Payload::Ctl { mission, .. })) = (&result, self.queries.get(&query).and_then(|q| q.payload.as_ref())) {
                    let mission = mission.clone();
                    let host = self.nodes[i].host.as_ref();
                    let revision = host.and_then(|h| h.heads().find(|(m, _)| **m == mission).map(|(_, mm)| mm.revision()));
                    let lineage = host.and_then(|h| h.replica(mission.as_str())).and_then(|r| r.config()).map_or(0, |c| mrmm_proto::chain::lineage_of(c.epoch));
                    if let Some(r) = revision {
                        self.inv.acked(mission.as_str(), lineage, r);
                        self.report.acked += 1;
                    }
                }
                let result = result.map(Answer::Json).map_err(Failure::answered);
                self.reply(query, result);
            }
            host::Command::Drop { query } => self.reply(query, Err(Failure::retry("dropped"))),
            host::Command::Serve { mission } => {
                self.nodes[i].served.insert(mission);
            }
            host::Command::Unserve { mission } => {
                self.nodes[i].served.remove(&mission);
            }
            // Planned here, as the driver does when no planner service is alive.
            host::Command::RequestPlan { mission, epoch, kind, request, local: true } => {
                let result = mrmm_core::mission::planning::plan(kind, &request).map(Box::new).map_err(Failure::fatal);
                let at = self.now + self.rng.gen_range(0.01..0.2);
                let inc = self.links.inc[i];
                self.queue.push(at, Ev::Local { node: i, inc, ev: Box::new(host::Event::Planned { mission, epoch, result }) });
            }
            // Asked by `host`.
            host::Command::RequestPlan { .. } | host::Command::SendPlan { .. } => {}
            host::Command::Refused(r) => {
                // Honest nodes only: a refusal is a chain message crossing a stale belief (a
                // node that left the mission's chain). Logged, not a violation.
                let name = self.nodes[i].name.clone();
                self.log(|| format!("{name} refused: {r}"));
            }
        }
        Ok(())
    }

    pub(super) fn robot(&mut self, i: usize, ev: robot::Event) -> Result<(), String> {
        let now = self.now;
        let name = self.nodes[i].name.clone();
        let Some(r) = self.nodes[i].robot.as_mut() else {
            return Ok(());
        };
        let before = r.executor().map(|e| (e.mission().to_string(), e.epoch(), e.progress().syncs_passed));
        let cmds = r.handle(now, ev);
        if let (Some((m, epoch, passed)), Some(e)) = (before, r.executor()) {
            if e.mission() == m && e.epoch() == epoch && e.progress().syncs_passed > passed {
                self.report.barriers += e.progress().syncs_passed - passed;
                self.inv.barrier_passed(&name, e)?;
            }
        }
        self.robot_commands(i, cmds)
    }

    /// A robot's commands, carried out by the production driver's step over the simulation's
    /// runtime.
    pub(super) fn robot_commands(&mut self, i: usize, cmds: Vec<robot::Command>) -> Result<(), String> {
        driver::carry_out::<Robot>(self, i, cmds)
    }

    /// One command of a robot's, as its driver carries it out; `Ok(false)`: the robot crashed
    /// (its last command).
    pub(super) fn robot_command(&mut self, i: usize, c: robot::Command) -> Result<bool, String> {
        // What it means on the network, as the driver carries it out: the links keep up
        // with its team, and say what goes out on which key.
        let out = self.nodes[i].links.egress(&c);
        let team = out.as_ref().and_then(|o| match &o.key {
            mrmm_proto::Key::TeamSync { team, .. } | mrmm_proto::Key::TeamArrive { team, .. } | mrmm_proto::Key::TeamRelease { team, .. } => Some(team.clone()),
            _ => None,
        });
        match &c {
            robot::Command::Reply(_) | robot::Command::Lead(_) | robot::Command::Telemetry(_) | robot::Command::TrafficReport { .. } => {}
            // An honest head planning for a robot not admitted yet: it re-sends.
            robot::Command::Refuse(e) => {
                let name = self.nodes[i].name.clone();
                self.log(|| format!("{name} refuses: {e}"));
            }
            robot::Command::JoinTeam { .. } | robot::Command::LeaveTeam => {
                self.beliefs.forget(i, |t| !matches!(t, Token::Member { .. }));
                self.liveliness(0.02);
                self.local_team(i)?;
            }
            robot::Command::Publish(a) | robot::Command::PublishIn(_, a) => {
                if let Some(team) = &team {
                    self.inv.arrival(team, a);
                }
            }
            robot::Command::Release(r) => {
                let name = self.nodes[i].name.clone();
                if let (Some(_), Some(e)) = (&team, self.nodes[i].robot.as_ref().and_then(|rb| rb.executor())) {
                    self.inv.release(&name, e, r)?;
                }
            }
            // Simulated bodies give no velocity commands, nor ROS 2 goals.
            robot::Command::Drive(_) | robot::Command::Nav(_) | robot::Command::Vda(_) => {}
            robot::Command::KeepCapabilities { now, .. } => self.nodes[i].kept_caps = Some(now.clone()),
            // Its last command: the node goes down as a crashed process does.
            robot::Command::Crash => {
                self.crash(i);
                return Ok(false);
            }
        }
        if let Some(out) = out {
            self.publish(i, out);
        }
        Ok(true)
    }

    /// The robot of node `i` changed team: its host hears of it at once (same process).
    pub(super) fn local_team(&mut self, i: usize) -> Result<(), String> {
        if self.nodes[i].host.is_none() {
            return Ok(());
        }
        let team = self.nodes[i].robot.as_ref().map(|r| r.team()).unwrap_or_default();
        self.host(i, host::Event::LocalTeam(team))
    }

    /// Who node `i` is, as its certificate would prove; `None` (the simulation's operator) acts
    /// as central does.
    pub(super) fn sender(&self, i: usize) -> Sender {
        let n = &self.nodes[i];
        match n.kind {
            Kind::Central => Sender::new(Role::Central, n.name.clone()),
            Kind::Host => Sender::new(Role::Host, n.name.clone()),
            Kind::Robot => Sender::new(Role::Robot, n.name.clone()),
        }
    }

    pub(super) fn asker(&self, asker: Option<usize>) -> Sender {
        asker.map_or_else(|| Sender::new(Role::Central, CENTRAL_HOST), |a| self.sender(a))
    }
}
