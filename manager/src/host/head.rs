//! The missions a host leads: their mission managers, what they wait to do until the chain has
//! committed it, their queryables and status publications.

use std::time::Duration;

use mrmm_peer::net;
use mrmm_peer::proto::{self, CommandAck, CtlAck, Member, MissionCtl, MissionStart, MissionView, RobotCommand};
use mrmm_planner::recipe::{MissionPlan, PlannerKind};
use zenoh::bytes::Encoding;
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;

use super::{ChainCmd, Host, Input, Tomb, PLAN_TIMEOUT};
use crate::central::ask;
use crate::chain::{self, Config};
use crate::error::ManagerError;
use crate::mission::{MCommand, MEvent, MissionManager, MissionSnapshot, MissionSpec};

/// How long a robot may take to accept a plan.
const ROBOT_TIMEOUT: Duration = Duration::from_secs(3);

/// A mission this node leads.
pub(super) struct Head {
    mm: MissionManager,
    /// The start query, answered once the first plans are out.
    start: Option<Query>,
    /// Effects waiting for the chain to commit the state that produced them.
    pending: Vec<MCommand>,
    /// The last state handed to the chain.
    proposed: Option<MissionSnapshot>,
    _queryables: Vec<Queryable<()>>,
}

impl Host {
    pub(super) async fn start(&mut self, q: Query) {
        let start: MissionStart = match proto::from_json("mission start", &net::query_payload(&q)) {
            Ok(s) => s,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        let spec = match MissionSpec::from_wire(start.spec) {
            Ok(s) => s,
            Err(e) => return net::reply_error(&q, &e).await,
        };
        let name = spec.name.clone();
        if self.heads.contains_key(&name) || self.replicas.get(&name).is_some_and(|r| r.config().is_some()) {
            return net::reply_error(&q, &format!("mission {name:?} is already hosted here")).await;
        }
        let queryables = match self.declare(&name).await {
            Ok(qs) => qs,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        let mut mm = MissionManager::new(spec, self.node.clone(), start.members.iter().map(|m| m.spec.clone()).collect());
        for m in &start.members {
            mm.set_time_scale(&m.spec.id, m.time_scale);
        }
        // The first replicas: members whose hosts are up, in id order.
        let replicas: Vec<String> = start
            .members
            .iter()
            .map(|m| m.spec.id.clone())
            .filter(|id| *id != self.node && self.hosts.contains(id))
            .take(mm.replicas())
            .collect();
        tracing::info!(mission = %name, ?replicas, "hosting mission");
        let snapshot = mm.snapshot();
        self.heads.insert(name.clone(), Head { mm, start: Some(q), pending: Vec::new(), proposed: None, _queryables: queryables });
        self.tombs.remove(&name);
        self.replicas.remove(&name);
        let now = self.now();
        let cmds = self.replica(&name).handle(now, chain::Event::Create { replicas, state: snapshot });
        self.apply(&name, cmds).await;
        self.set_pool(&name);
        self.run(&name, MEvent::Start).await;
    }

    async fn declare(&self, name: &str) -> Result<Vec<Queryable<()>>, ManagerError> {
        let mut out = Vec::new();
        for (key, kind) in [(proto::mission_ctl(name), 0), (proto::mission_view(name), 1), (proto::mission_marginal(name), 2)] {
            let (tx, n) = (self.tx.clone(), name.to_string());
            let q = self
                .session
                .declare_queryable(key)
                .callback(move |q| {
                    let _ = tx.send(match kind {
                        0 => Input::Ctl(n.clone(), q),
                        1 => Input::View(n.clone(), q),
                        _ => Input::Marginal(n.clone(), q),
                    });
                })
                .await
                .map_err(ManagerError::zenoh)?;
            out.push(q);
        }
        Ok(out)
    }

    /// This node won the mission's chain: go on from the replicated state.
    pub(super) async fn lead(&mut self, name: &str, config: Config, state: MissionSnapshot) -> Vec<ChainCmd> {
        if self.heads.contains_key(name) {
            return vec![];
        }
        let mm = match MissionManager::restore(state, self.node.clone()) {
            Ok(mm) => mm,
            Err(e) => {
                tracing::warn!(mission = %name, "cannot take over: {e}");
                return vec![];
            }
        };
        let queryables = match self.declare(name).await {
            Ok(q) => q,
            Err(e) => {
                tracing::warn!(mission = %name, "cannot take over: {e}");
                return vec![];
            }
        };
        tracing::info!(mission = %name, chain_epoch = config.epoch, chain = ?config.chain, "took over the mission");
        // Robots already running the committed plans go on; those that missed them get them.
        let pending = mm.current_assignments();
        let lost: Vec<String> = mm.members().filter(|id| !self.robots.contains(*id)).cloned().collect();
        let back: Vec<_> = self.robots.iter().filter_map(|id| mm.lost(id).cloned()).collect();
        let planning = mm.planning();
        self.heads.insert(name.to_string(), Head { mm, start: None, pending, proposed: None, _queryables: queryables });
        let mut out = Vec::new();
        if !lost.is_empty() {
            out.extend(self.step(name, MEvent::Lost { ids: lost }).await);
        }
        for spec in back {
            out.extend(self.step(name, MEvent::Joined(spec)).await);
        }
        if planning {
            // The predecessor died while planning: ask again.
            if let Some(h) = self.heads.get_mut(name) {
                let cmds = h.mm.replan_now();
                self.effects(name, cmds);
            }
        }
        self.set_pool(name);
        self.publish(name).await;
        out
    }

    pub(super) async fn step_down(&mut self, name: &str, why: &str) {
        if let Some(h) = self.heads.remove(name) {
            tracing::info!(mission = %name, "no longer managing the mission: {why}");
            if let Some(q) = h.start {
                net::reply_error(&q, &format!("mission {name}: {why}")).await;
            }
        }
    }

    /// Runs one event of a led mission, hands the new state to the chain, acts on what is committed.
    pub(super) async fn run(&mut self, name: &str, ev: MEvent) {
        let cmds = self.step(name, ev).await;
        self.apply(name, cmds).await;
        let more = self.flush(name).await;
        self.apply(name, more).await;
    }

    /// Runs one event; returns the chain's commands for the new state.
    async fn step(&mut self, name: &str, ev: MEvent) -> Vec<ChainCmd> {
        let telemetry = matches!(ev, MEvent::Telemetry { .. });
        let Some(h) = self.heads.get_mut(name) else { return vec![] };
        let cmds = h.mm.handle(ev);
        self.effects(name, cmds);
        if telemetry {
            return vec![];
        }
        let Some(h) = self.heads.get_mut(name) else { return vec![] };
        let snapshot = h.mm.snapshot();
        if h.proposed.as_ref() == Some(&snapshot) {
            return vec![];
        }
        h.proposed = Some(snapshot.clone());
        let now = self.now();
        let out = self.replicas.get_mut(name).map(|r| r.handle(now, chain::Event::Propose(snapshot))).unwrap_or_default();
        self.set_pool(name);
        self.publish(name).await;
        out
    }

    /// Plans are asked for at once; everything the outside sees waits for the commit.
    fn effects(&mut self, name: &str, cmds: Vec<MCommand>) {
        for c in cmds {
            match c {
                MCommand::RequestPlan { epoch, kind, request } => self.request_plan(name, epoch, kind, request),
                other => {
                    if let Some(h) = self.heads.get_mut(name) {
                        h.pending.push(other);
                    }
                }
            }
        }
    }

    fn request_plan(&self, name: &str, epoch: u64, kind: PlannerKind, request: proto::PlanRequest) {
        let (session, tx, mission) = (self.session.clone(), self.tx.clone(), name.to_string());
        let prefix = format!("mrmm/planner/{}/alive/", kind.as_str());
        let service = self.planners.iter().any(|k| k.starts_with(&prefix));
        tokio::spawn(async move {
            let result = if service {
                match proto::to_json(&request) {
                    Ok(body) => ask::<MissionPlan>(&session, &proto::planner(kind.as_str()), Some(body), PLAN_TIMEOUT).await,
                    Err(e) => Err(e.to_string()),
                }
            } else {
                // No planner service reachable (central down): plan here.
                tracing::info!(%mission, "no planner service alive; planning locally");
                tokio::task::spawn_blocking(move || crate::planner_service::plan(kind, &request))
                    .await
                    .unwrap_or_else(|e| Err(format!("planner crashed: {e}")))
            };
            let _ = tx.send(Input::Planned { mission, epoch, result: result.map(Box::new) });
        });
    }

    /// Carries out the effects of committed state; returns the chain's commands if the mission ends.
    pub(super) async fn flush(&mut self, name: &str) -> Vec<ChainCmd> {
        let committed = self.replicas.get(name).is_some_and(|r| r.committed().is_some_and(|c| c == r.version().1));
        if !committed {
            return vec![];
        }
        let Some(h) = self.heads.get_mut(name) else { return vec![] };
        let pending = std::mem::take(&mut h.pending);
        for c in pending {
            match c {
                MCommand::SendPlan { robot, assignment } => {
                    let session = self.session.clone();
                    tokio::spawn(async move {
                        let cmd = RobotCommand::Plan(assignment);
                        let result = match proto::to_json(&cmd) {
                            Ok(body) => ask::<CommandAck>(&session, &proto::robot_cmd(&robot), Some(body), ROBOT_TIMEOUT).await,
                            Err(e) => Err(e.to_string()),
                        };
                        if let Err(e) = result {
                            tracing::warn!(%robot, "plan not delivered: {e}");
                        }
                    });
                }
                MCommand::Started => {
                    let view = self.view(name, false);
                    if let (Some(h), Some(view)) = (self.heads.get_mut(name), view) {
                        if let Some(q) = h.start.take() {
                            net::reply_json(&q, &view).await;
                        }
                    }
                }
                MCommand::Failed { error } => {
                    if let Some(q) = self.heads.get_mut(name).and_then(|h| h.start.take()) {
                        net::reply_error(&q, &format!("mission {name}: planning failed: {error}")).await;
                    }
                    return self.end(name);
                }
                MCommand::RequestPlan { .. } => {}
            }
        }
        vec![]
    }

    /// Ends a led mission; the chain's commands carry the end to every node of its chain.
    fn end(&mut self, name: &str) -> Vec<ChainCmd> {
        self.heads.remove(name);
        self.tombs.insert(name.to_string(), Tomb { promised: self.replicas.get(name).map_or(0, |r| r.promised()), ended: true });
        let now = self.now();
        self.replicas.get_mut(name).map(|r| r.handle(now, chain::Event::End)).unwrap_or_default()
    }

    pub(super) async fn ctl(&mut self, name: &str, q: Query) {
        let ctl: MissionCtl = match proto::from_json("mission control", &net::query_payload(&q)) {
            Ok(c) => c,
            Err(e) => return net::reply_error(&q, &e.to_string()).await,
        };
        if !self.heads.contains_key(name) {
            return net::reply_error(&q, &format!("mission {name:?} is not managed here")).await;
        }
        match ctl {
            MissionCtl::Joined { member: Member { spec, time_scale } } => {
                if let Some(h) = self.heads.get_mut(name) {
                    h.mm.set_time_scale(&spec.id, time_scale);
                }
                self.run(name, MEvent::Joined(spec)).await;
            }
            MissionCtl::Left { ids } => {
                // Robots that are gone were lost: they rejoin when they come back.
                let (alive, dead): (Vec<String>, Vec<String>) = ids.into_iter().partition(|id| self.robots.contains(id));
                self.run(name, MEvent::Lost { ids: dead }).await;
                self.run(name, MEvent::Left { ids: alive }).await;
            }
            MissionCtl::Terminate => {
                let epoch = self.heads.get(name).map_or(0, |h| h.mm.epoch());
                if let Some(sq) = self.heads.get_mut(name).and_then(|h| h.start.take()) {
                    net::reply_error(&sq, &format!("mission {name} was terminated")).await;
                }
                tracing::info!(mission = %name, "mission terminated");
                let cmds = self.end(name);
                self.apply(name, cmds).await;
                return net::reply_json(&q, &CtlAck { ok: true, epoch }).await;
            }
        }
        let epoch = self.heads.get(name).map_or(0, |h| h.mm.epoch());
        net::reply_json(&q, &CtlAck { ok: true, epoch }).await;
    }

    pub(super) async fn answer_view(&self, name: &str, q: Query) {
        match self.view(name, true) {
            Some(v) => net::reply_json(&q, &v).await,
            None => net::reply_error(&q, &format!("mission {name:?} is not managed here")).await,
        }
    }

    pub(super) async fn answer_marginal(&self, name: &str, q: Query) {
        let add = match q.parameters().get("add") {
            None => Ok(1),
            Some(v) => v
                .parse::<i64>()
                .ok()
                .filter(|a| *a != 0 && a.abs() <= 1000)
                .ok_or_else(|| format!("add={v}: give a non-zero whole number, e.g. add=1 or add=-1")),
        };
        let answer = add.and_then(|add| {
            self.heads.get(name).ok_or_else(|| format!("mission {name:?} is not managed here")).and_then(|h| h.mm.marginal(add))
        });
        match answer {
            Ok(m) => net::reply_json(&q, &m).await,
            Err(e) => net::reply_error(&q, &e).await,
        }
    }

    pub(super) async fn telemetry(&mut self, s: Sample) {
        let Ok(t) = proto::decode_telemetry(&s.payload().to_bytes()) else {
            tracing::debug!("dropped payload on {}", s.key_expr());
            return;
        };
        let wall = self.now();
        let Some((name, scale)) = self.heads.iter().find(|(_, h)| h.mm.has(&t.id)).map(|(n, h)| (n.clone(), h.mm.time_scale(&t.id)))
        else {
            return;
        };
        self.run(&name, MEvent::Telemetry { now: wall * scale, t: Box::new(t) }).await;
    }

    pub(super) async fn planned(&mut self, name: &str, epoch: u64, result: Result<Box<MissionPlan>, String>) {
        let ev = match result {
            Ok(plan) => MEvent::PlanReady { epoch, plan },
            Err(error) => MEvent::PlanFailed { epoch, error },
        };
        self.run(name, ev).await;
    }

    /// A member lost is taken out (the team goes on without it); a lost member back rejoins.
    pub(super) async fn robot_liveliness(&mut self, id: &str, up: bool) {
        let names: Vec<String> = self
            .heads
            .iter()
            .filter(|(_, h)| if up { h.mm.lost(id).is_some() } else { h.mm.has(id) })
            .map(|(n, _)| n.clone())
            .collect();
        for name in names {
            let ev = match self.heads.get(&name).and_then(|h| h.mm.lost(id).cloned()) {
                Some(spec) if up => {
                    tracing::info!(mission = %name, robot = %id, "lost member back: it rejoins");
                    MEvent::Joined(spec)
                }
                _ => MEvent::Lost { ids: vec![id.to_string()] },
            };
            self.run(&name, ev).await;
        }
    }

    /// Tells a led mission's replica which nodes may join its chain: members with a host up.
    fn set_pool(&mut self, name: &str) {
        let Some(h) = self.heads.get(name) else { return };
        let nodes: Vec<String> = h.mm.members().filter(|id| **id != self.node && self.hosts.contains(*id)).cloned().collect();
        let k = h.mm.replicas();
        let now = self.now();
        if let Some(r) = self.replicas.get_mut(name) {
            let _ = r.handle(now, chain::Event::Pool { nodes, k });
        }
    }

    pub(super) async fn status_tick(&mut self) {
        let names: Vec<String> = self.heads.keys().cloned().collect();
        for name in names {
            self.set_pool(&name);
            self.publish(&name).await;
        }
    }

    /// A led mission as the operator sees it, with its chain.
    fn view(&self, name: &str, with_plans: bool) -> Option<MissionView> {
        let h = self.heads.get(name)?;
        let mut v = h.mm.view(with_plans);
        if let Some(c) = self.replicas.get(name).and_then(|r| r.config()) {
            v.manager.chain_epoch = c.epoch;
            v.manager.chain = c.chain.clone();
        }
        Some(v)
    }

    async fn publish(&self, name: &str) {
        let Some(view) = self.view(name, false) else { return };
        match serde_json::to_vec(&view) {
            Ok(bytes) => {
                if let Err(e) = self.session.put(proto::mission_status(name), bytes).encoding(Encoding::APPLICATION_JSON).await {
                    tracing::warn!("status publication failed: {e}");
                }
            }
            Err(e) => tracing::warn!("cannot encode the status of {name}: {e}"),
        }
    }
}
