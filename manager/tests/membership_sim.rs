//! Seeded simulation of the system manager against mission managers that also act on their own
//! (issue 5, invariant 3): operators create, move and terminate at random; robots die and come
//! back; a mission manager takes a returning robot back by itself (as heads do while central is
//! away) and reports it. The mission managers are modelled by applying the system manager's
//! commands. Invariant: after the system manager has answered each event, every robot is in at
//! most one mission manager's team, and the system manager's own table agrees.
//!
//! `cargo test -p mrmm-manager --test membership_sim` runs 1 000 seeds; `MRMM_SIM_SEEDS=N` more;
//! `MRMM_SIM_SEED=S` replays one.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_manager::system::{Command, Event, Request, SystemManager};
use mrmm_peer::proto::{ManagerView, MissionCtl, MissionMetrics, MissionStatus, MissionView, RobotInfo, RobotView};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[derive(Default)]
struct Managers {
    teams: BTreeMap<String, BTreeSet<String>>,
    /// Robots a manager lost and will take back when they return.
    lost: BTreeMap<String, BTreeSet<String>>,
}

fn view(name: &str, robots: &BTreeSet<String>) -> MissionView {
    MissionView {
        name: name.into(),
        recipe: "patrol".into(),
        planner: "patrol".into(),
        status: MissionStatus::Running,
        robots: robots.iter().cloned().collect(),
        teams: BTreeMap::new(),
        manager: ManagerView { node: "central".into(), epoch: 1, chain_epoch: 1, chain: vec![] },
        metrics: MissionMetrics::default(),
        summary: serde_json::Value::Null,
        params: BTreeMap::new(),
        error: None,
        plans: None,
    }
}

struct World {
    sm: SystemManager,
    m: Managers,
    alive: BTreeSet<String>,
    now: f64,
    req: u64,
}

impl World {
    /// Feeds an event and plays the mission managers and robots for every command, recursively.
    fn event(&mut self, ev: Event) -> Result<(), String> {
        let mut queue = vec![ev];
        while let Some(ev) = queue.pop() {
            for c in self.sm.handle(self.now, ev) {
                match c {
                    Command::FetchInfo { id } if self.alive.contains(&id) => queue.push(Event::RobotRegistered(RobotInfo {
                        id: id.clone(),
                        robot_type: "ground".into(),
                        capabilities: vec![],
                        max_speed: 1.0,
                        endpoints: vec![],
                        time_scale: 1.0,
                    })),
                    Command::StartMission { start, .. } => {
                        let name = start.spec.name.clone();
                        let team: BTreeSet<String> = start.members.iter().map(|m| m.spec.id.clone()).collect();
                        self.m.teams.insert(name.clone(), team.clone());
                        queue.push(Event::MissionStarted { mission: name.clone(), result: Ok(Box::new(view(&name, &team))) });
                    }
                    Command::Ctl { mission, ctl } => {
                        let Some(team) = self.m.teams.get_mut(&mission) else { continue };
                        match ctl {
                            MissionCtl::Joined { member } => {
                                team.insert(member.spec.id);
                            }
                            MissionCtl::Left { ids } => {
                                for id in ids {
                                    team.remove(&id);
                                    // Like the hosts: a robot that is gone was lost and may come back.
                                    let lost = self.m.lost.entry(mission.clone()).or_default();
                                    if self.alive.contains(&id) {
                                        lost.remove(&id);
                                    } else {
                                        lost.insert(id);
                                    }
                                }
                            }
                            MissionCtl::Terminate => {
                                self.m.teams.remove(&mission);
                                self.m.lost.remove(&mission);
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
        self.check()
    }

    fn check(&self) -> Result<(), String> {
        let mut seen: BTreeMap<&String, &String> = BTreeMap::new();
        for (m, team) in &self.m.teams {
            for r in team {
                if let Some(other) = seen.insert(r, m) {
                    return Err(format!("robot {r} is in missions {other} and {m}"));
                }
            }
        }
        Ok(())
    }

    fn operator(&mut self, request: Request) -> Result<(), String> {
        self.req += 1;
        self.event(Event::Operator { req: self.req, request })
    }
}

fn run(seed: u64) -> Result<(), String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rng.gen_range(2..=7);
    let ids: Vec<String> = (1..=n).map(|i| format!("r{i}")).collect();
    let mut w = World { sm: SystemManager::new("c".into(), 0.0), m: Managers::default(), alive: BTreeSet::new(), now: 0.0, req: 0 };
    w.event(Event::HostAlive { node: "central".into() })?;
    for id in &ids {
        w.alive.insert(id.clone());
        w.event(Event::RobotAlive { id: id.clone() })?;
    }
    let names = ["m1", "m2", "m3"];
    for step in 0..120 {
        w.now += rng.gen_range(0.05..2.0);
        let id = ids[rng.gen_range(0..n)].clone();
        let name = names[rng.gen_range(0..names.len())];
        match rng.gen_range(0..9) {
            0 => {
                let body = format!(
                    r#"{{"name": "{name}", "recipe": "patrol", "count": {}, "params": {{"waypoints": [[0,0],[10,0],[10,10]]}}}}"#,
                    rng.gen_range(1..=2)
                );
                w.operator(Request::Create(body.into_bytes()))?;
            }
            1 => {
                let to = if rng.gen_bool(0.3) { "null".to_string() } else { format!("\"{name}\"") };
                w.operator(Request::Move(format!(r#"{{"robot": "{id}", "to": {to}}}"#).into_bytes()))?;
            }
            2 => w.operator(Request::Terminate(format!(r#"{{"name": "{name}"}}"#).into_bytes()))?,
            3 if w.alive.contains(&id) => {
                // A robot dies: its mission manager takes it out on its own and remembers it.
                w.alive.remove(&id);
                for (m, team) in w.m.teams.iter_mut() {
                    if team.remove(&id) {
                        w.m.lost.entry(m.clone()).or_default().insert(id.clone());
                    }
                }
                w.event(Event::RobotGone { id: id.clone() })?;
            }
            4 if !w.alive.contains(&id) => {
                // It comes back; the manager that lost it notices a little later (below).
                w.alive.insert(id.clone());
                w.event(Event::RobotAlive { id: id.clone() })?;
            }
            5 => {
                // A manager takes back a lost robot that is alive again, and reports: the
                // operator may have put it in another mission meanwhile.
                let back: Vec<String> = w.m.lost.iter().filter(|(_, l)| l.contains(&id)).map(|(m, _)| m.clone()).collect();
                if !w.alive.contains(&id) {
                    continue;
                }
                for m in back {
                    if let Some(lost) = w.m.lost.get_mut(&m) {
                        lost.remove(&id);
                    }
                    if let Some(team) = w.m.teams.get_mut(&m) {
                        team.insert(id.clone());
                        let v = view(&m, team);
                        w.event(Event::MissionStatus(Box::new(v)))?;
                    }
                }
            }
            _ => {
                // A periodic report of some mission.
                if let Some((m, team)) = w.m.teams.iter().nth(rng.gen_range(0..w.m.teams.len().max(1))) {
                    let v = view(m, team);
                    w.event(Event::MissionStatus(Box::new(v)))?;
                }
            }
        }
        w.event(Event::Tick).map_err(|e| format!("step {step}: {e}"))?;
    }
    // The system manager's table agrees with the managers' teams for live robots.
    w.req += 1;
    let table = w.sm.handle(w.now, Event::Operator { req: w.req, request: Request::Robots });
    let Some(Command::Reply { result: Ok(v), .. }) = table.first() else { return Err(format!("no robots table: {table:?}")) };
    let views: Vec<RobotView> = serde_json::from_value(v.clone()).map_err(|e| e.to_string())?;
    for r in views.iter().filter(|r| w.alive.contains(&r.id)) {
        let holder = w.m.teams.iter().find(|(_, t)| t.contains(&r.id)).map(|(m, _)| m.clone());
        if let (Some(a), Some(b)) = (&r.mission, &holder) {
            if a != b {
                return Err(format!("robot {}: the system manager says {a}, the managers say {b}", r.id));
            }
        }
    }
    Ok(())
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

#[test]
fn every_robot_is_in_at_most_one_mission() {
    if let Some(seed) = env_u64("MRMM_SIM_SEED") {
        run(seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        return;
    }
    for seed in 0..env_u64("MRMM_SIM_SEEDS").unwrap_or(1000) {
        if let Err(e) = run(seed) {
            panic!("seed {seed}: {e}; replay with MRMM_SIM_SEED={seed}");
        }
    }
}
