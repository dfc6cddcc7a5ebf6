//! The operator's side: random commands, missions started directly on hosts, barrier plans handed out.

use super::*;

impl World {
    pub(super) fn robot_names(&self) -> Vec<String> {
        self.nodes.iter().filter(|n| n.kind == Kind::Robot).map(|n| n.name.clone()).collect()
    }

    pub(super) fn operate(&mut self) -> Result<(), String> {
        let active = self.now < self.end();
        match self.cfg.ops {
            Ops::Barriers { .. } => Ok(()),
            Ops::Random => self.random_command(active),
            Ops::OneMission => {
                self.queue.push(self.now + 0.25, Ev::Op);
                if !active {
                    // Quiet: the operator stops, controls not yet acknowledged included.
                    self.ctls.cancel("p");
                }
                // The start (a query) may be lost: asked again until some node holds the mission
                // (a world where it never started would check nothing).
                let started = self.nodes.iter().any(|n| n.host.as_ref().is_some_and(|h| h.replica("p").is_some()));
                if self.now < Time::from_secs(0.6) || (!started && self.now < Time::from_secs(5.0)) {
                    self.start_one_mission();
                } else {
                    self.admit_unaware();
                }
                if self.now >= Time::from_secs(0.6) && active && self.rng.gen_bool(0.15) && !self.random_ctl() {
                    return Ok(());
                }
                for (id, mission, ctl) in self.ctls.due(self.now) {
                    self.ask_mission(None, mission.clone().as_str(), Payload::Ctl { mission, ctl }, Ctx::OpCtl(id), mrmm_core::timeouts::QUERY_S);
                }
                Ok(())
            }
        }
    }

    /// Random: the operator's next command to central, and now and then a robot's camera breaks
    /// or one is fitted.
    fn random_command(&mut self, active: bool) -> Result<(), String> {
        let next = self.now + self.rng.gen_range(1.0..3.0);
        self.queue.push(next, Ev::Op);
        let Some(c) = self.nodes.iter().position(|n| n.kind == Kind::Central) else {
            return Ok(());
        };
        if !active || !self.links.up[c] {
            return Ok(());
        }
        let robots = self.robot_names();
        let (req, request) = self.op.command(&mut self.rng, &robots);
        self.log(|| format!("operator: {request:?}"));
        self.central(c, central::Event::System(system::Event::Operator { req: Req::Query(req), request }))?;
        if self.swap_rng.gen_bool(0.2) {
            self.hand_over(c)?;
        }
        if self.caps_rng.gen_bool(0.3) {
            let robot = robots[self.caps_rng.gen_range(0..robots.len())].clone();
            let has = self.index(&robot).and_then(|i| self.nodes[i].robot.as_ref()).is_some_and(|r| r.info(vec![]).capabilities.iter().any(|c| c == "camera"));
            let (req, request) = self.op.camera(robot, has);
            self.log(|| format!("operator: {request:?}"));
            self.central(c, central::Event::System(system::Event::Operator { req: Req::Query(req), request }))?;
        }
        Ok(())
    }

    /// A robot not in a mission takes the place of one of its members, as central's charging
    /// policy has a spare relieve a low robot (a hand-over: one control, the plan carried on),
    /// drawn from a stream of its own.
    fn hand_over(&mut self, c: usize) -> Result<(), String> {
        let Some(sys) = self.nodes[c].central.as_ref().map(|n| n.system()) else { return Ok(()) };
        let assignment = sys.durable().assignment;
        let missions: Vec<MissionName> = assignment.values().cloned().collect::<BTreeSet<_>>().into_iter().collect();
        if missions.is_empty() {
            return Ok(());
        }
        let to = missions[self.swap_rng.gen_range(0..missions.len())].clone();
        let members: Vec<RobotId> = assignment.iter().filter(|(_, m)| **m == to).map(|(r, _)| r.clone()).collect();
        let others: Vec<String> = self.robot_names().into_iter().filter(|r| assignment.get(r.as_str()) != Some(&to)).collect();
        if members.is_empty() || others.is_empty() {
            return Ok(());
        }
        let out = members[self.swap_rng.gen_range(0..members.len())].clone();
        let robot = others[self.swap_rng.gen_range(0..others.len())].clone();
        let (req, request) = self.op.replace(robot, to, out);
        self.log(|| format!("operator: {request:?}"));
        self.central(c, central::Event::System(system::Event::Operator { req: Req::Query(req), request }))
    }

    /// OneMission, as central does for members that join or come back: a robot the mission's
    /// state counts in (or lost) that does not know the whole team (it restarted, or others
    /// joined since its plan) is admitted with the team, so robot heads may plan for it and it
    /// takes their chain messages.
    fn admit_unaware(&mut self) {
        let mut counted: BTreeSet<String> = BTreeSet::new();
        // The managers central would name: the chain of the newest configuration.
        let mut chain: Option<(u64, Vec<NodeId>)> = None;
        for n in &self.nodes {
            let Some(r) = n.host.as_ref().and_then(|h| h.replica("p")) else {
                continue;
            };
            if let Some(state) = r.state() {
                counted.extend(state.members.iter().chain(&state.lost).map(|m| m.spec.id.to_string()));
            }
            if let Some(c) = r.config() {
                if chain.as_ref().is_none_or(|(e, _)| c.epoch > *e) {
                    chain = Some((c.epoch, c.chain.clone()));
                }
            }
        }
        self.managers = chain.map(|(_, c)| c).unwrap_or_default();
        let unaware: Vec<String> = counted
            .iter()
            .filter(|r| {
                let teams = self.index(r).and_then(|i| self.nodes[i].robot.as_ref()).map(|rb| rb.team()).unwrap_or_default();
                !teams.iter().any(|(m, ids)| m == "p" && counted.iter().all(|c| ids.contains(c)))
            })
            .cloned()
            .collect();
        let team: Vec<String> = counted.into_iter().collect();
        for r in unaware {
            self.admit(&r, &team);
        }
    }

    /// OneMission: a random robot leaves the team or joins it (queued as the operator's
    /// control); false when the draw changes nothing (the last member stays).
    fn random_ctl(&mut self) -> bool {
        let robots = self.robot_names();
        let r = robots[self.rng.gen_range(0..robots.len())].clone();
        let ctl = if self.team.contains(&r) && self.team.len() > 1 {
            self.team.remove(&r);
            MissionCtl::Left { ids: vec![r.into()] }
        } else if !self.team.contains(&r) {
            self.team.insert(r.clone());
            self.admit_one(&r);
            let spec = RobotSpec { id: r.into(), robot_type: "ground".into(), x: 0.0, y: 0.0, speed: 1.0, turn_rate: None, reach_m: None };
            MissionCtl::Joined { member: Member { spec, time_scale: TIME_SCALE, capabilities: vec![] } }
        } else {
            return false;
        };
        self.ctls.push("p", ctl, vec![]);
        true
    }

    /// OneMission: mission `p` of every robot, on the first mission host.
    pub(super) fn start_one_mission(&mut self) {
        let robots = self.robot_names();
        self.team = robots.iter().cloned().collect();
        let members = robots
            .iter()
            .enumerate()
            .map(|(i, r)| Member {
                spec: RobotSpec { id: r.clone().into(), robot_type: "ground".into(), x: i as f64 * 2.0, y: -3.0, speed: 1.0, turn_rate: None, reach_m: None },
                time_scale: TIME_SCALE,
                capabilities: vec![],
            })
            .collect();
        let params = cheap_params(true).into_iter().map(|(k, v)| (k, v.to_string())).collect();
        let spec = MissionSpecWire {
            name: "p".into(),
            recipe_name: "patrol".into(),
            recipe_xml: mrmm_planner::recipe::bank("patrol").unwrap_or_default().into(),
            planner: "patrol".into(),
            params,
            replicas: 2,
            map: None,
            paused: false,
        };
        let host = self.nodes.iter().find(|n| n.kind == Kind::Host).map(|n| n.name.clone()).unwrap_or_else(|| robots[0].clone());
        for r in &robots {
            self.admit_one(r);
        }
        self.ask(
            None,
            &host,
            Payload::HostStart(Box::new(MissionStart { spec, members, anew: false, lineage: 0 })),
            Ctx::OpStart,
            mrmm_core::timeouts::START_S,
        );
    }

    /// OneMission: admits robot `r` to mission `p` with the operator's team.
    pub(super) fn admit_one(&mut self, r: &str) {
        let team: Vec<String> = self.team.iter().cloned().collect();
        self.admit(r, &team);
    }

    /// Admits robot `r` to mission `p` (as the system manager does): its managers are the host
    /// and any member of `team`, its members `team` (and `r`).
    pub(super) fn admit(&mut self, r: &str, team: &[String]) {
        let mut team = team.to_vec();
        if !team.iter().any(|t| t == r) {
            team.push(r.to_string());
        }
        let mut managers: Vec<NodeId> = self.nodes.iter().filter(|n| n.kind == Kind::Host).map(|n| NodeId::from(&n.name)).collect();
        managers.extend(self.managers.iter().cloned());
        managers.extend(team.iter().map(NodeId::from));
        managers.sort();
        managers.dedup();
        let admit = RobotCommand::Admit { mission: "p".into(), managers, members: team.iter().map(RobotId::from).collect() };
        self.log(|| format!("operator: admit {r} to p"));
        self.ask(None, r, Payload::RobotCmd(admit), Ctx::OpStart, mrmm_core::timeouts::QUERY_S);
    }

    /// Barriers: every robot gets the same plan of barriers with work between them. With
    /// `teams` > 1 the robots are split (round robin) into leaf teams `b/t0`, `b/t1`, …: each
    /// plan starts with a barrier of the whole mission `b`, and the rounds' barriers are each
    /// team's own.
    pub(super) fn hand_out_barrier_plans(&mut self, points: u32, rounds: u32, barrier: mrmm_proto::BarrierMode, teams: u32) {
        let robots = self.robot_names();
        let teams = teams.max(1) as usize;
        let team_of = |i: usize| if teams == 1 { "b".to_string() } else { format!("b/t{}", i % teams) };
        for (i, r) in robots.iter().enumerate() {
            let mine: Vec<RobotId> = robots.iter().enumerate().filter(|(k, _)| team_of(*k) == team_of(i)).map(|(_, r)| RobotId::from(r)).collect();
            let mut steps = vec![];
            let mut scopes = vec![];
            if teams > 1 {
                steps.push(Step::Sync { point: 0, scope: Some(String::new()) });
                scopes.push(mrmm_proto::ScopeMembers { team: "b".into(), members: robots.iter().map(RobotId::from).collect() });
            }
            let first = steps.len();
            steps.push(Step::Sync { point: 0, scope: None });
            for p in 1..points {
                let x = (i as f64 + p as f64) * self.rng.gen_range(0.5..2.0);
                steps.push(Step::Navigate { x, y: self.rng.gen_range(-3.0..3.0), speed: None });
                steps.push(Step::Sync { point: p, scope: None });
            }
            steps.push(Step::Hold { seconds: Some(self.rng.gen_range(0.0..2.0)) });
            steps.push(Step::Loop { to: first + 1, rounds: Some(rounds) });
            let team = team_of(i);
            let assignment = PlanAssignment {
                handover: None,
                mission: "b".into(),
                epoch: 1,
                subteam: format!("{team}/ground"),
                team: team.clone(),
                members: mine,
                plan: RobotPlan { robot: r.clone().into(), robot_type: "ground".into(), slot: i, steps, team: team.strip_prefix("b/").unwrap_or("").into() },
                managers: vec![],
                barrier,
                scopes,
                map: None,
            };
            let j = self.index(r).unwrap_or(0);
            let from = Sender::new(Role::Host, "planner");
            let cmds = self.nodes[j]
                .robot
                .as_mut()
                .map(|rb| rb.handle(Time::ZERO, robot::Event::Command { cmd: RobotCommand::Plan(Box::new(assignment)), from }))
                .unwrap_or_default();
            let _ = self.robot_commands(j, cmds);
        }
    }
}
