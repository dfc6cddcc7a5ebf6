//! Queries: routed to whoever serves their key, served by the machines, answered to whoever asked (or timed out).

use mrmm_proto::Key;

use super::*;

impl World {
    /// A machine's question (`mrmm_core::ask`), routed by its key to whoever serves it — the
    /// robot, the host, the mission's head, the planner service — with its body decoded as that
    /// server's driver decodes it. `wait`: its timeout (`None`: the default query timeout).
    pub(super) fn ask_key(&mut self, asker: Option<usize>, key: &Key, body: Option<&[u8]>, wait: Option<f64>, ctx: Ctx) -> Result<(), String> {
        let wait = wait.unwrap_or(mrmm_core::timeouts::QUERY_S);
        let body = body.unwrap_or_default();
        let decode = |what: &'static str| format!("{what} on {key} does not decode");
        match key {
            Key::RobotInfo(id) => self.ask(asker, id.as_str(), Payload::RobotInfo, ctx, wait),
            Key::RobotCmd(id) => {
                let cmd = mrmm_proto::from_json("robot command", body).map_err(|_| decode("robot command"))?;
                self.ask(asker, id.as_str(), Payload::RobotCmd(cmd), ctx, wait)
            }
            Key::HostStart(host) => {
                let start = mrmm_proto::from_json("mission start", body).map_err(|_| decode("mission start"))?;
                self.ask(asker, host.as_str(), Payload::HostStart(Box::new(start)), ctx, wait)
            }
            Key::MissionCtl(mission) => {
                let ctl = mrmm_proto::from_json("mission control", body).map_err(|_| decode("mission control"))?;
                self.ask_mission(asker, mission.as_str(), Payload::Ctl { mission: mission.clone(), ctl }, ctx, wait)
            }
            Key::MissionView(mission) => self.ask_mission(asker, mission.as_str(), Payload::View(mission.clone()), ctx, wait),
            Key::Planner(kind) => {
                let kind = [mrmm_planner::recipe::PlannerKind::Patrol, mrmm_planner::recipe::PlannerKind::Coverage]
                    .into_iter()
                    .find(|k| k.as_str() == kind)
                    .ok_or_else(|| format!("no planner {kind}"))?;
                let request = mrmm_proto::from_json("plan request", body).map_err(|_| decode("plan request"))?;
                self.ask(asker, CENTRAL_HOST, Payload::Planner(request, kind), ctx, wait)
            }
            other => return Err(format!("a question on {other}, which nobody in the simulation serves")),
        }
        Ok(())
    }

    /// A query to the node named `server`.
    pub(super) fn ask(&mut self, asker: Option<usize>, server: &str, payload: Payload, ctx: Ctx, wait: f64) {
        let server = self.index(server);
        self.send_query(asker, server, payload, ctx, wait);
    }

    /// A query to whoever serves `mission` (the operator reaches every node).
    pub(super) fn ask_mission(&mut self, asker: Option<usize>, mission: &str, payload: Payload, ctx: Ctx, wait: f64) {
        let servers: Vec<usize> =
            (0..self.nodes.len()).filter(|j| self.nodes[*j].served.contains(mission) && asker.is_none_or(|a| self.links.connected(a, *j))).collect();
        let server = (!servers.is_empty()).then(|| servers[self.rng.gen_range(0..servers.len())]);
        self.send_query(asker, server, payload, ctx, wait);
    }

    pub(super) fn send_query(&mut self, asker: Option<usize>, server: Option<usize>, payload: Payload, ctx: Ctx, wait: f64) {
        let qid = self.next_qid;
        self.next_qid += 1;
        let asker_inc = asker.map_or(0, |a| self.links.inc[a]);
        let reachable = server.filter(|s| asker.is_none_or(|a| self.links.connected(a, *s)));
        self.queries.insert(qid, Pending { asker, asker_inc, server: server.unwrap_or(usize::MAX), payload: Some(payload), ctx, done: false });
        match reachable {
            // Nobody serves the key: the query ends at once, empty.
            None => {
                let at = self.now + self.delay();
                self.queue.push(at, Ev::Answer { qid, result: Err(Failure::retry("no queryable")) });
            }
            Some(_) => {
                self.report.sent += 1;
                if !self.lost() {
                    let at = self.now + self.delay();
                    self.queue.push(at, Ev::Query(qid));
                }
                self.queue.push(self.now + wait, Ev::Timeout(qid));
            }
        }
    }

    /// The query reaches its server.
    pub(super) fn serve(&mut self, qid: u64) -> Result<(), String> {
        let Some(q) = self.queries.get_mut(&qid) else {
            return Ok(());
        };
        let (s, asker) = (q.server, q.asker);
        if s >= self.nodes.len() || !self.links.up[s] || asker.is_some_and(|a| !self.links.connected(a, s)) {
            return Ok(());
        }
        let Some(payload) = q.payload.clone() else {
            return Ok(());
        };
        let from = self.asker(asker);
        match payload {
            Payload::RobotCmd(cmd) => self.serve_robot_cmd(qid, s, cmd, from)?,
            Payload::RobotInfo => {
                if let Some(r) = self.nodes[s].robot.as_ref() {
                    let info = serde_json::to_value(r.info(vec![])).map_err(|e| Failure::fatal(e.to_string()));
                    self.reply(qid, info.map(Answer::Json));
                }
            }
            Payload::HostStart(start) => self.serve_host_start(qid, s, &start, &from)?,
            Payload::Ctl { mission, ctl } => {
                let ev = self.host_question(s, qid, &Key::MissionCtl(mission), Some(&ctl), &from)?;
                self.host(s, ev)?;
            }
            Payload::View(mission) => {
                let ev = self.host_question(s, qid, &Key::MissionView(mission), None::<&()>, &from)?;
                self.host(s, ev)?;
            }
            Payload::Planner(request, kind) => {
                if self.nodes[s].kind == Kind::Central {
                    let result = mrmm_core::mission::planning::plan(kind, &request)
                        .map_err(Failure::fatal)
                        .and_then(|p| serde_json::to_value(p).map(Answer::Json).map_err(|e| Failure::fatal(e.to_string())));
                    self.reply(qid, result);
                }
            }
        }
        Ok(())
    }

    /// A command query reaches robot node `s`: through the robot's ingress, as its driver takes
    /// it, and answered as the driver answers.
    fn serve_robot_cmd(&mut self, qid: u64, s: usize, cmd: RobotCommand, from: Sender) -> Result<(), String> {
        let now = self.now;
        let Some(r) = self.nodes[s].robot.as_mut() else {
            return Ok(());
        };
        let msg = Wire::json(mrmm_proto::Key::RobotCmd(r.id().into()), &cmd, from);
        let ev = r
            .ingress(mrmm_core::robot::Incoming { key: &msg.key, payload: &msg.payload, put: true, from: msg.from.as_ref() })
            .map_err(|e| format!("{} refused an honest command: {e}", self.nodes[s].name))?;
        let Some(r) = self.nodes[s].robot.as_mut() else {
            return Ok(());
        };
        let cmds = r.handle(now, ev);
        // A refusal (its sender may not send this, yet) may be retried: as the driver does.
        let reply = cmds.iter().find_map(|c| match c {
            robot::Command::Reply(r) => Some(r.clone().map_err(Failure::fatal)),
            robot::Command::Refuse(e) => Some(Err(Failure::answered(mrmm_proto::ErrorReply::coded(mrmm_proto::ErrorCode::Refused, e.clone())))),
            _ => None,
        });
        self.robot_commands(s, cmds)?;
        // An admission changes whom the robot trusts: its host hears of it at once.
        self.local_team(s)?;
        if let Some(r) = reply {
            self.reply(qid, r.and_then(|ack| serde_json::to_value(ack).map(Answer::Json).map_err(|e| Failure::fatal(e.to_string()))));
        }
        Ok(())
    }

    /// A mission start reaches host node `s`. Central starts a mission again from its journal: a
    /// new lineage, which the host may take only when no other live node replicates the same (or
    /// a newer) one — an older lineage's replicas are fenced off by the new lineage's epochs.
    fn serve_host_start(&mut self, qid: u64, s: usize, start: &MissionStart, from: &Sender) -> Result<(), String> {
        let mission = start.spec.name.clone();
        let again = self.nodes.iter().any(|n| n.central.as_ref().is_some_and(|c| c.system().restarting(mission.as_str())));
        let leads = |w: &World| w.nodes[s].host.as_ref().is_some_and(|h| h.heads().any(|(m, _)| *m == mission));
        let before = leads(self);
        let lineage = start.lineage;
        let holders: Vec<String> = (0..self.nodes.len())
            .filter(|n| *n != s && self.links.up[*n])
            .filter(|n| {
                self.nodes[*n]
                    .host
                    .as_ref()
                    .and_then(|h| h.replica(mission.as_str()))
                    .is_some_and(|r| r.state().is_some() && mrmm_proto::chain::lineage_of(r.version().0) >= lineage)
            })
            .map(|n| self.nodes[n].name.clone())
            .collect();
        if again && !before {
            self.inv.lineage_started(mission.as_str(), lineage);
        }
        let key = Key::HostStart(self.nodes[s].name.clone().into());
        let ev = self.host_question(s, qid, &key, Some(start), from)?;
        self.host(s, ev)?;
        if again && !before && leads(self) && !holders.is_empty() {
            return Err(format!("{} started {mission} anew while {holders:?} still replicate it", self.nodes[s].name));
        }
        Ok(())
    }

    /// Question `qid` as node `s`'s host driver takes it: its body as JSON, translated by the
    /// host's own ingress — which refuses no honest question.
    fn host_question<B: serde::Serialize>(&self, s: usize, qid: u64, key: &Key, body: Option<&B>, from: &Sender) -> Result<host::Event, String> {
        let payload = body.map(|b| serde_json::to_vec(b).unwrap_or_default()).unwrap_or_default();
        let key = key.to_string();
        host::question(host::Question { key: &key, params: "", payload: &payload, from: Some(from), query: qid })
            .map_err(|e| format!("{}'s host refused an honest question on {key}: {e}", self.nodes[s].name))
    }

    /// The server answers query `qid` (or lets it go): the answer travels back to the asker.
    pub(super) fn reply(&mut self, qid: u64, result: Result<Answer, Failure>) {
        let Some(q) = self.queries.get(&qid) else {
            return;
        };
        if q.done {
            return;
        }
        if !self.lost() {
            let at = self.now + self.delay();
            self.queue.push(at, Ev::Answer { qid, result });
        }
    }

    /// An answer reaches the asker.
    pub(super) fn answer(&mut self, qid: u64, result: Result<Answer, Failure>) -> Result<(), String> {
        let Some(q) = self.queries.get_mut(&qid) else {
            return Ok(());
        };
        if q.done {
            return Ok(());
        }
        let arrives = match q.asker {
            None => true,
            Some(a) => {
                self.links.up[a] && self.links.inc[a] == q.asker_inc && (q.server >= self.nodes.len() || result.is_err() || self.links.connected(a, q.server))
            }
        };
        // A query's end (an answer, or its timeout) reaches only the process that asked: one that
        // restarted since is another process, which never made this query.
        if q.asker.is_some_and(|a| self.links.inc[a] != q.asker_inc) {
            self.queries.remove(&qid);
            return Ok(());
        }
        if !arrives && result.is_ok() {
            return Ok(());
        }
        q.done = true;
        let (asker, ctx) = (q.asker, q.ctx.clone());
        self.queries.remove(&qid);
        if asker.is_some_and(|a| !self.links.up[a]) {
            return Ok(());
        }
        let key = "the simulation's query";
        let value = |r: Result<Answer, Failure>| r.map(|Answer::Json(v)| v);
        match (ctx, asker) {
            (Ctx::Central(then), Some(a)) => {
                let ev = then.answer(key, value(result));
                if let system::Event::CtlDone { id, result } = &ev {
                    self.log(|| format!("ctl {id} answered: {result:?}"));
                }
                self.central(a, central::Event::System(ev))
            }
            (Ctx::Host(then), Some(a)) => {
                let ev = then.answer(key, value(result));
                if let host::Event::Planned { mission, epoch, result } = &ev {
                    let ok = result.as_ref().map(|_| ()).map_err(|f| f.error.clone());
                    self.log(|| format!("plan of {mission} epoch {epoch} answered: {ok:?}"));
                }
                self.host(a, ev)
            }
            (Ctx::OpCtl(id), _) => {
                let result = json::<CtlAck>(result).map(|_| ());
                self.ctls.done(self.now, id, result);
                Ok(())
            }
            (Ctx::OpStart, _) => Ok(()),
            (_, None) => Ok(()),
        }
    }
}
