//! The energy experiment's simulated fleet for one policy's day: the robots' bodies and
//! executors, the patrol replanned as its manager does, central's charging policy carried out,
//! and what is measured.

use std::collections::{BTreeMap, VecDeque};

use anyhow::anyhow;
use mrmm_core::body::battery::Battery;
use mrmm_core::body::{Body, Limits};
use mrmm_core::central::charging::{self, Charging};
use mrmm_core::robot::executor::{Command as Exec, Event, Executor};
use mrmm_maps::{Map, NavGraph, Point, Space};
use mrmm_planner::recipe::{self, Recipe};
use mrmm_proto::map::Charger;
use mrmm_proto::plan::RobotSpec;
use mrmm_proto::{BarrierMode, Handover, MapInfo, MapRef, MissionView, PlanAssignment, Pose, RobotId, RobotStatus, RobotView, Time};

use super::{Day, Policy, Row, Trace, DT, MAP, SPEED, TURN, VISIT_R};

/// The simulated fleet: bodies, the patrol's executors, the policy, and what is measured.
pub(super) struct World<'a> {
    day: &'a Day,
    graph: &'a NavGraph,
    map: Map,
    space: Space,
    recipe: &'a Recipe,
    policy: Policy,
    charging: Charging,
    info: MapInfo,
    ids: Vec<RobotId>,
    bodies: Vec<Body>,
    /// The patrol's robots (indices), in the order they were planned.
    members: Vec<usize>,
    /// Members the last plan left out for want of reach.
    held: Vec<RobotId>,
    execs: BTreeMap<usize, Executor>,
    /// Where a robot off the patrol still drives (a route along the lanes).
    legs: Vec<VecDeque<Point>>,
    dead: Vec<bool>,
    epoch: u64,
    /// The patrol's members changed: replan.
    pub(super) changed: bool,
    m: Measures,
}

/// What a run measures.
#[derive(Default)]
struct Measures {
    /// Per vertex: when last visited, and the gaps between visits.
    last: Vec<Option<f64>>,
    gaps: Vec<Vec<f64>>,
    /// The longest of those gaps yet.
    longest: f64,
    /// The vertex each robot is at.
    at: Vec<Option<usize>>,
    started: bool,
    short_s: f64,
    lowest: Vec<f64>,
    errands: usize,
    replans: usize,
    handovers: usize,
    charging_s: f64,
    team: Vec<(f64, f64)>,
    lowest_series: Vec<(f64, f64)>,
}

impl<'a> World<'a> {
    pub(super) fn new(day: &'a Day, graph: &'a NavGraph, recipe: &'a Recipe, policy: Policy) -> anyhow::Result<World<'a>> {
        let map = Map::Graph(graph.clone());
        let space = Space::new(&map, 0.0).map_err(|e| anyhow!("{e}"))?;
        let n = day.team + if policy == Policy::Mrmm { day.spares } else { 0 };
        let starts = space.farthest(graph.vertices[0].at, n, |_| true).map_err(|e| anyhow!("{e}"))?;
        let ids: Vec<RobotId> = (1..=n).map(|i| RobotId::from(format!("r{i}"))).collect();
        let model = day.model();
        let bodies = starts
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let body = Body::new(Pose { x: p.x, y: p.y, theta: 0.0 }, Limits { max_speed: SPEED, max_turn_rate: TURN });
                if !policy.batteries() {
                    return body;
                }
                let spread = if day.team > 1 { i as f64 / (day.team - 1) as f64 } else { 0.0 };
                let charge = if i < day.team { 1.0 - (1.0 - day.lowest_start) * spread } else { 1.0 };
                body.with_battery(Battery::new(model, charge))
            })
            .collect();
        let chargers = graph.chargers().map(|v| Charger { name: v.name.clone(), at: mrmm_proto::geom::Point { x: v.at.x, y: v.at.y } }).collect();
        let (min, max) = graph.bounds();
        let info = MapInfo {
            name: MAP.into(),
            format: "open_rmf".into(),
            bytes: 0,
            hash: MAP.into(),
            size: String::new(),
            min: mrmm_proto::geom::Point { x: min.x, y: min.y },
            max: mrmm_proto::geom::Point { x: max.x, y: max.y },
            superseded: false,
            chargers,
        };
        let nv = graph.vertices.len();
        let m = Measures { last: vec![None; nv], gaps: vec![Vec::new(); nv], at: vec![None; n], lowest: vec![1.0; n], ..Measures::default() };
        Ok(World {
            day,
            graph,
            map,
            space,
            recipe,
            policy,
            charging: Charging::new(day.charging),
            info,
            ids,
            bodies,
            members: (0..day.team).collect(),
            held: vec![],
            execs: BTreeMap::new(),
            legs: vec![VecDeque::new(); n],
            dead: vec![false; n],
            epoch: 0,
            changed: false,
            m,
        })
    }

    /// A new plan for the patrol's members from where they stand, as its manager replans on a
    /// leave or a join.
    pub(super) fn replan(&mut self) -> anyhow::Result<()> {
        self.changed = false;
        self.epoch += 1;
        self.execs.clear();
        if self.members.is_empty() {
            return Ok(());
        }
        self.m.replans += 1;
        let specs: Vec<RobotSpec> = self
            .members
            .iter()
            .map(|&i| {
                let p = self.bodies[i].pose();
                // What its battery reports, as the manager has it from telemetry.
                let reach_m = self.bodies[i].battery().and_then(|b| b.state(SPEED).reach_m);
                RobotSpec { id: self.ids[i].clone(), robot_type: "ground".into(), x: p.x, y: p.y, speed: SPEED, turn_rate: None, reach_m }
            })
            .collect();
        let params = BTreeMap::from([
            ("waypoints".to_string(), "all".to_string()),
            ("seed".to_string(), self.day.seed.to_string()),
            ("turn_rate".to_string(), TURN.to_string()),
        ]);
        let planned = recipe::build_on(self.recipe, &params, &specs, Some(&self.map)).map_err(|e| anyhow!("replanning {} robots: {e}", specs.len()))?.to_wire();
        // Members left out for want of reach hold (no executor) and are no barrier's members.
        self.held = planned.held.clone();
        let members: Vec<RobotId> = planned.plans.iter().map(|p| p.robot.clone()).collect();
        for plan in planned.plans {
            let i = self.ids.iter().position(|id| *id == plan.robot).ok_or_else(|| anyhow!("the planner placed robot {}, not in the fleet", plan.robot))?;
            self.legs[i].clear();
            self.execs.insert(
                i,
                Executor::new(PlanAssignment {
                    handover: None,
                    mission: "patrol".into(),
                    epoch: self.epoch,
                    team: "patrol".into(),
                    subteam: "patrol/ground".into(),
                    members: members.clone(),
                    plan,
                    managers: vec![],
                    barrier: BarrierMode::Mesh,
                    scopes: vec![],
                    map: None,
                }),
            );
        }
        Ok(())
    }

    /// The patrol's executors: a tick each, their barrier announcements heard by the others.
    pub(super) fn tick(&mut self, t: f64) {
        let mut heard = Vec::new();
        for (&i, e) in &mut self.execs {
            for c in e.handle(Time::from_secs(t), Event::Tick { body_idle: self.bodies[i].idle() }) {
                match c {
                    Exec::Navigate { x, y, then, speed } => self.bodies[i].navigate_through(x, y, then, speed),
                    Exec::Hold => self.bodies[i].hold(),
                    Exec::Face { x, y } => self.bodies[i].face(x, y),
                    Exec::Publish(a) => heard.push((i, a)),
                    Exec::Release(_) | Exec::Lead(_) | Exec::PublishIn(..) => {}
                }
            }
        }
        for (from, a) in heard {
            for (&j, e) in &mut self.execs {
                if j != from {
                    e.handle(Time::from_secs(t), Event::Heard(a.clone()));
                }
            }
        }
        if !self.m.started && !self.execs.is_empty() && self.execs.values().all(|e| e.progress().syncs_passed >= 1) {
            self.m.started = true;
        }
    }

    /// Bodies move (batteries drain, or charge); robots off the patrol drive their legs; visits,
    /// charges and the dead are counted.
    pub(super) fn step(&mut self, t: f64) {
        for i in 0..self.bodies.len() {
            if !self.execs.contains_key(&i) && self.bodies[i].idle() {
                if let Some(p) = self.legs[i].pop_front() {
                    self.bodies[i].navigate_to(p.x, p.y);
                }
            }
            self.bodies[i].step(DT);
            let battery = self.bodies[i].battery().map(|b| (b.charge(), b.charging(), b.empty()));
            if let Some((charge, charging, empty)) = battery {
                self.m.lowest[i] = self.m.lowest[i].min(charge);
                if charging {
                    self.m.charging_s += DT;
                }
                if empty && !self.dead[i] {
                    self.dead[i] = true;
                    tracing::info!(robot = %self.ids[i], t, "ran dry");
                    if let Some(k) = self.members.iter().position(|&m| m == i) {
                        self.members.remove(k);
                        self.changed = true;
                    }
                }
            }
            self.visit(t, i);
        }
        // A member held out of the plan for want of reach patrols nothing.
        let working = self.members.iter().filter(|&&i| !self.held.contains(&self.ids[i])).count();
        if working < self.day.team {
            self.m.short_s += DT;
        }
    }

    /// A patrol member at a vertex visits it (and every vertex drawn on the same spot).
    fn visit(&mut self, t: f64, i: usize) {
        let p = self.bodies[i].pose();
        let here = self.graph.vertices.iter().position(|v| (v.at.x - p.x).hypot(v.at.y - p.y) <= VISIT_R);
        if here != self.m.at[i] && self.m.started && self.execs.contains_key(&i) {
            if let Some(v) = here {
                let spot = self.graph.vertices[v].at;
                for w in (0..self.graph.vertices.len()).filter(|&w| self.graph.vertices[w].at == spot) {
                    if let Some(l) = self.m.last[w] {
                        if t - l > self.m.longest {
                            self.m.longest = t - l;
                            tracing::debug!(vertex = w, t, gap = t - l, by = %self.ids[i], "the day's longest gap yet");
                        }
                        self.m.gaps[w].push(t - l);
                    }
                    self.m.last[w] = Some(t);
                }
            }
        }
        self.m.at[i] = here;
    }

    /// Central's look: the charging policy over the fleet as central sees it, its commands
    /// carried out.
    pub(super) fn look(&mut self, t: f64) -> anyhow::Result<()> {
        let robots: Vec<RobotView> = (0..self.ids.len()).map(|i| self.view(i)).collect();
        let members: Vec<&str> = self.members.iter().map(|&i| self.ids[i].as_str()).collect();
        let patrol = MissionView {
            map: Some(MapRef { name: MAP.into(), hash: MAP.into() }),
            held: self.held.iter().filter(|id| members.contains(&id.as_str())).cloned().collect(),
            ..MissionView::running("patrol", "patrol", "central", self.epoch, &members)
        };
        let fleet = charging::Fleet { robots: &robots, missions: std::slice::from_ref(&patrol), maps: std::slice::from_ref(&self.info) };
        let before: Vec<RobotId> = self.charging.errands().keys().cloned().collect();
        for c in self.charging.handle(Time::from_secs(t), fleet) {
            self.carry_out(c)?;
        }
        self.m.errands += self.charging.errands().keys().filter(|id| !before.contains(id)).count();
        Ok(())
    }

    /// Robot `i` as central's robots view shows it.
    fn view(&self, i: usize) -> RobotView {
        let member = self.members.contains(&i);
        let standing = self.bodies[i].idle() && self.legs[i].is_empty();
        RobotView {
            id: self.ids[i].clone(),
            robot_type: "ground".into(),
            capabilities: vec![],
            status: if member || !standing { RobotStatus::Busy } else { RobotStatus::Idle },
            mission: member.then(|| "patrol".into()),
            pose: Some(self.bodies[i].pose()),
            behaviour: Some(if member {
                "plan".into()
            } else if standing {
                "hold".into()
            } else {
                "goto".into()
            }),
            goal: self.bodies[i].goal().map(|(x, y)| mrmm_proto::geom::Point { x, y }),
            last_mission: None,
            stuck: None,
            battery: self.bodies[i].battery().map(|b| b.state(SPEED)),
            vehicle: None,
        }
    }

    fn carry_out(&mut self, c: charging::Command) -> anyhow::Result<()> {
        let index = |id: &RobotId| self.ids.iter().position(|r| r == id).ok_or_else(|| anyhow!("the policy named robot {id}, not in the fleet"));
        match c {
            charging::Command::Move { robot, to } => {
                let i = index(&robot)?;
                self.members.retain(|&m| m != i);
                if to.is_some() {
                    self.members.push(i);
                }
                self.execs.remove(&i);
                self.bodies[i].hold();
                self.changed = true;
            }
            charging::Command::Replace { robot, out, .. } => {
                let (by, out) = (index(&robot)?, index(&out)?);
                let (a, b) = (self.bodies[by].pose(), self.bodies[out].pose());
                let goal = self.bodies[out].goal().unwrap_or((b.x, b.y));
                let (ahead, behind) = ((a.x - goal.0).hypot(a.y - goal.1), (b.x - goal.0).hypot(b.y - goal.1));
                tracing::debug!(by = %robot, out = %self.ids[out], apart = (a.x - b.x).hypot(a.y - b.y), by_to_goal = ahead, out_to_goal = behind, "hand-over");
                self.hand_over(out, by);
            }
            charging::Command::Goto { robot, x, y, .. } => {
                let i = index(&robot)?;
                let from = self.space.locate_robot(robot.as_str(), i, to_point(self.bodies[i].pose())).map_err(|e| anyhow!("{e}"))?;
                // A relief goes to where the low robot stands, on a lane between vertices: the way ends there.
                let to = self.space.locate_robot("goal", 0, Point::new(x, y)).map_err(|e| anyhow!("{e}"))?;
                let route = self.space.route(&from, &to).ok_or_else(|| anyhow!("no way from robot {robot} to ({x}, {y})"))?;
                self.legs[i] = route.into_iter().chain([Point::new(x, y)]).collect();
                self.bodies[i].hold();
            }
            charging::Command::Plug { robot, on } => {
                let i = index(&robot)?;
                if on {
                    self.legs[i].clear();
                    self.bodies[i].hold();
                }
                if let Some(b) = self.bodies[i].battery_mut() {
                    b.set_charging(on);
                }
            }
        }
        Ok(())
    }

    /// Robot `by` takes member `out`'s place as the mission's manager hands it over: the same
    /// plans under a new epoch, `by` on `out`'s from where `out` is, the others going on where
    /// they are (`out` without a plan: a leave and a join, replanned).
    fn hand_over(&mut self, out: usize, by: usize) {
        self.members.retain(|&m| m != out);
        self.members.push(by);
        self.bodies[out].hold();
        // Standing on a vertex already, it visits it as a member now.
        self.m.at[by] = None;
        self.legs[by].clear();
        self.bodies[by].hold();
        let Some(old) = self.execs.remove(&out) else {
            self.execs.remove(&by);
            self.changed = true;
            return;
        };
        self.epoch += 1;
        let members: Vec<RobotId> = self.members.iter().map(|&i| self.ids[i].clone()).collect();
        let at = old.progress();
        let handover = Some(Handover { planned: old.assignment.planned(), step: at.step, round: at.round });
        for e in self.execs.values_mut() {
            let a = PlanAssignment { epoch: self.epoch, members: members.clone(), handover, ..e.assignment.clone() };
            e.carry_on(a);
        }
        let mut plan = old.assignment.plan.clone();
        plan.robot = self.ids[by].clone();
        let a = PlanAssignment { epoch: self.epoch, members, handover, plan, ..old.assignment };
        self.execs.insert(by, Executor::taking_over(a, at.step, at.round));
        self.m.handovers += 1;
    }

    pub(super) fn sample(&mut self, t: f64) {
        let lowest = self.bodies.iter().filter_map(|b| b.battery().map(Battery::charge)).fold(1.0, f64::min);
        self.m.team.push((t / 3600.0, self.members.len() as f64));
        self.m.lowest_series.push((t / 3600.0, lowest));
    }

    pub(super) fn finish(self, end: f64) -> (Row, Trace) {
        let m = self.m;
        // The time since a vertex's last visit at the day's end is one more gap (a patrol that
        // stopped leaves its vertices unvisited; the day's end must show it).
        let gaps: Vec<Vec<f64>> = m.gaps.iter().zip(&m.last).map(|(g, l)| g.iter().copied().chain(Some(end - l.unwrap_or(0.0))).collect()).collect();
        let avg = gaps.iter().map(|g| g.iter().sum::<f64>() / g.len() as f64).sum::<f64>() / gaps.len().max(1) as f64;
        let worst = gaps.iter().flatten().copied().fold(0.0, f64::max);
        let row = Row {
            policy: self.policy,
            robots: self.ids.len(),
            avg_s: avg,
            worst_s: worst,
            short_s: m.short_s,
            lowest: m.lowest.iter().copied().fold(1.0, f64::min),
            under_5: m.lowest.iter().filter(|&&c| c < 0.05).count(),
            died: self.dead.iter().filter(|&&d| d).count(),
            errands: m.errands,
            replans: m.replans,
            handovers: m.handovers,
            charging_s: m.charging_s,
        };
        (row, Trace { policy: self.policy, team: m.team, lowest: m.lowest_series })
    }
}

fn to_point(p: Pose) -> Point {
    Point::new(p.x, p.y)
}
