//! `mrmm op mission …`: create, terminate, list and inspect missions, and ask what one more robot
//! would bring.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{anyhow, Context};
use mrmm_net::client::Client;
use mrmm_proto::{self as proto, Marginal, MissionCreate, MissionPause, MissionTerminate, MissionUpdate, MissionView};
use serde_json::Value;

/// A mission's recipe parameters on the command line (a create's, or an update's new ones).
#[derive(Debug, clap::Args)]
pub struct Params {
    /// Patrol waypoints as JSON, e.g. '[[0,0],[20,0],[20,15]]', or `all` (every vertex of the
    /// mission's graph map).
    #[arg(long)]
    waypoints: Option<String>,
    /// Coverage region as JSON, e.g. '[[0,0],[30,0],[30,30],[0,30]]'.
    #[arg(long)]
    region: Option<String>,
    /// Other recipe parameters (repeatable): key=value (`TEAM/key=value` for one team).
    #[arg(long = "param")]
    params: Vec<String>,
}

#[derive(Debug, clap::Subcommand)]
pub enum Mission {
    /// Create a mission (`mrmm/system/cmd/mission/create`).
    Create {
        name: String,
        /// A recipe of the bank (patrol, coverage) or a recipe file (sent inline).
        #[arg(long)]
        recipe: String,
        /// Exactly these robots (comma-separated).
        #[arg(long, value_delimiter = ',')]
        robots: Vec<String>,
        /// Or this many idle robots. Neither: an equal share of the fleet.
        #[arg(long)]
        count: Option<usize>,
        #[command(flatten)]
        params: Params,
        /// The mission host to run its manager on (default: central).
        #[arg(long)]
        host: Option<String>,
        /// Robots replicating the mission manager's state; the first takes over if the manager's
        /// node dies (default 2).
        #[arg(long)]
        replicas: Option<usize>,
        /// Plan on this map of central's (`mrmm op maps`): routes along its corridors or edges.
        #[arg(long)]
        map: Option<String>,
    },
    /// Terminate a mission; its robots become idle.
    Terminate { name: String },
    /// Change a running mission (`mrmm/system/cmd/mission/update`): checked in full, then
    /// replanned as its next epoch; its robots stay.
    Update {
        name: String,
        #[command(flatten)]
        params: Params,
        /// Plan on this map of central's from now on ("" for none).
        #[arg(long)]
        map: Option<String>,
    },
    /// Pause a mission: its robots hold where they are (`mrmm/system/cmd/mission/pause`).
    Pause { name: String },
    /// Resume a paused mission: its team forms again from where it stands.
    Resume { name: String },
    /// The missions table (`mrmm/system/missions`).
    List,
    /// One mission with its per-robot plans (`mrmm/system/missions/<name>`).
    Show { name: String },
    /// Predicted metric with `add` robots more (negative: fewer) (`mrmm/missions/<name>/marginal`).
    #[command(allow_negative_numbers = true)]
    Marginal {
        name: String,
        #[arg(long, default_value_t = 1)]
        add: i64,
    },
}

pub async fn exec(client: &Client, m: Mission, json: bool) -> anyhow::Result<()> {
    let none = None::<&()>;
    match m {
        Mission::Create { name, recipe, robots, count, params, host, replicas, map } => {
            let recipe = if Path::new(&recipe).is_file() { std::fs::read_to_string(&recipe).with_context(|| format!("cannot read {recipe}"))? } else { recipe };
            let p = params.into_map()?;
            let req = MissionCreate {
                name: name.into(),
                recipe,
                robots: (!robots.is_empty()).then_some(robots.iter().map(Into::into).collect()),
                count,
                params: p,
                host: host.map(Into::into),
                replicas,
                map,
            };
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Create), Some(&req)).await?;
            if json {
                return super::print_json(&v);
            }
            let m: MissionView = serde_json::from_value(v)?;
            println!("mission {} {} on {}: {} robots ({})", m.name, status(&m), m.manager.node, m.robots.len(), m.robots.join(", "));
        }
        Mission::Update { name, params, map } => {
            let req = MissionUpdate { name: name.into(), params: params.into_map()?, map, teams: Default::default() };
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Update), Some(&req)).await?;
            if json {
                return super::print_json(&v);
            }
            println!("mission {} updated: it replans its robots as its next epoch", v["mission"].as_str().unwrap_or("?"));
        }
        Mission::Pause { name } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Pause), Some(&MissionPause { name: name.into() })).await?;
            if json {
                return super::print_json(&v);
            }
            println!("mission {} paused: its robots hold where they are", v["mission"].as_str().unwrap_or("?"));
        }
        Mission::Resume { name } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Resume), Some(&MissionPause { name: name.into() })).await?;
            if json {
                return super::print_json(&v);
            }
            println!("mission {} resumed: its team forms again from where it stands", v["mission"].as_str().unwrap_or("?"));
        }
        Mission::Terminate { name } => {
            let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::Terminate), Some(&MissionTerminate { name: name.into() })).await?;
            if json {
                return super::print_json(&v);
            }
            println!("terminated {}; idle again: {}", v["mission"].as_str().unwrap_or("?"), v["robots"]);
        }
        Mission::List => {
            let v: Value = client.query(proto::Key::SystemMissions, none).await?;
            if json {
                return super::print_json(&v);
            }
            let ms: Vec<MissionView> = serde_json::from_value(v)?;
            print!("{}", table(&ms));
        }
        Mission::Show { name } => {
            let v: Value = client.query(proto::Key::SystemMission(name.into()), none).await?;
            if json {
                return super::print_json(&v);
            }
            print!("{}", details(&serde_json::from_value(v)?));
        }
        Mission::Marginal { name, add } => {
            let key = proto::keys::marginal_selector(&name, add);
            let v: Value = client.query(&key, none).await?;
            if json {
                return super::print_json(&v);
            }
            let g: Marginal = serde_json::from_value(v)?;
            println!("{}: {} {:.2} with {} robots → {:.2} with {}", g.mission, g.metric, g.current, g.robots, g.predicted, g.with_robots);
        }
    }
    Ok(())
}

/// One mission in full: its row, its manager chain, its teams, its plans.
fn details(m: &MissionView) -> String {
    let mut out = table(std::slice::from_ref(m));
    if !m.manager.chain.is_empty() {
        out.push_str(&format!("manager chain (epoch {}): {}\n", m.manager.chain_epoch, m.manager.chain.join(" → ")));
    }
    if m.team_views.is_empty() {
        for (team, ids) in &m.teams {
            out.push_str(&format!("team {team}: {}\n", ids.join(", ")));
        }
    } else {
        out.push_str(&team_tree(m));
    }
    for p in m.plans.iter().flatten() {
        out.push_str(&format!("plan {} (slot {}): {} steps\n", p.robot, p.slot, p.steps.len()));
    }
    out
}

/// A mission's team tree: each team on its own line below its parent, a leaf team with its
/// planner, members and barriers passed.
fn team_tree(m: &MissionView) -> String {
    let mut out = format!("teams of {}:\n", m.name);
    let mut shown: Vec<&str> = vec![m.name.as_str()];
    for t in &m.team_views {
        // The inner teams above this leaf that are not shown yet.
        let parts: Vec<&str> = t.team.split('/').collect();
        for depth in 2..parts.len() {
            let inner = &t.team[..parts[..depth].iter().map(|p| p.len() + 1).sum::<usize>() - 1];
            if !shown.contains(&inner) {
                shown.push(inner);
                out += &format!("{}{}\n", "  ".repeat(depth - 1), parts[depth - 1]);
            }
        }
        let members = if t.members.is_empty() { "no members".to_string() } else { t.members.join(", ") };
        let min = if t.min > 0 { format!(", min {}", t.min) } else { String::new() };
        out += &format!(
            "{}{} ({}{min}): {members}; {} barriers passed\n",
            "  ".repeat(parts.len() - 1),
            parts.last().unwrap_or(&""),
            t.planner,
            t.barriers_passed
        );
    }
    out
}

fn status(m: &MissionView) -> String {
    serde_json::to_value(m.status).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default()
}

/// The missions table.
/// A mission's robots in one cell: sorted naturally, the middle elided beyond eight.
fn robots_cell(ids: &[mrmm_proto::RobotId]) -> String {
    let mut ids: Vec<&str> = ids.iter().map(|id| id.as_str()).collect();
    ids.sort_by(|a, b| mrmm_proto::natural_cmp(a, b));
    match ids.len() {
        0..=8 => ids.join(","),
        n => format!("{},…,{} ({n})", ids[..3].join(","), ids[n - 1]),
    }
}

pub fn table(ms: &[MissionView]) -> String {
    let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.1}"));
    let rows: Vec<Vec<String>> = ms
        .iter()
        .map(|m| {
            vec![
                m.name.to_string(),
                if m.requires.is_empty() { m.recipe.clone() } else { format!("{} [{}]", m.recipe, m.requires.join(",")) },
                status(m),
                robots_cell(&m.robots),
                format!("{}/{}", m.manager.node, m.manager.epoch),
                m.metrics.rounds.to_string(),
                m.metrics.sync_points_passed.to_string(),
                f(m.metrics.avg_idleness),
                f(m.metrics.worst_idleness),
            ]
        })
        .collect();
    super::super::table::render(&["MISSION", "RECIPE", "STATUS", "ROBOTS", "MANAGER/EPOCH", "ROUNDS", "SYNCS", "AVG IDLE s", "WORST IDLE s"], &rows)
}

impl Params {
    /// As the operator API takes them: waypoints and region as JSON (or `all`), the rest as
    /// strings.
    fn into_map(self) -> anyhow::Result<BTreeMap<String, Value>> {
        let Params { waypoints, region, params } = self;
        let mut p: BTreeMap<String, Value> = BTreeMap::new();
        for (k, v) in [("waypoints", waypoints), ("region", region)] {
            match v {
                Some(v) if v.trim() == "all" => {
                    p.insert(k.into(), Value::String("all".into()));
                }
                Some(v) => {
                    p.insert(k.into(), serde_json::from_str(&v).with_context(|| format!("--{k}: not JSON"))?);
                }
                None => {}
            }
        }
        for kv in params {
            let (k, v) = kv.split_once('=').ok_or_else(|| anyhow!("--param {kv:?}: expected key=value"))?;
            p.insert(k.into(), Value::String(v.into()));
        }
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::{robots_cell, team_tree};
    use mrmm_proto::{MissionView, TeamView};

    #[test]
    fn robots_are_listed_naturally_and_elided_beyond_eight() {
        let ids = |v: &[&str]| v.iter().map(Into::into).collect::<Vec<mrmm_proto::RobotId>>();
        assert_eq!(robots_cell(&ids(&["r10", "r2", "r1"])), "r1,r2,r10");
        let many: Vec<mrmm_proto::RobotId> = (1..=50).rev().map(|i| format!("r{i}").into()).collect();
        assert_eq!(robots_cell(&many), "r1,r2,r3,…,r50 (50)");
    }

    #[test]
    fn the_team_tree_shows_inner_teams_once_and_each_leaf_below_its_parent() {
        let leaf = |team: &str, planner: &str, members: &[&str], passed: u32, min: usize| TeamView {
            team: team.into(),
            planner: planner.into(),
            members: members.iter().map(Into::into).collect(),
            barriers_passed: passed,
            min,
            wants: String::new(),
            robot_type: None,
            requires: vec![],
        };
        let mut m: MissionView = serde_json::from_value(serde_json::json!({
            "name": "s", "recipe": "custom", "planner": "patrol", "status": "running", "robots": [], "teams": {},
            "manager": {"node": "central", "epoch": 1, "chain_epoch": 0, "chain": []},
            "metrics": mrmm_proto::MissionMetrics::default(), "summary": null
        }))
        .expect("view");
        m.team_views = vec![
            leaf("s/site/wing/north", "patrol", &["r1", "r2"], 7, 1),
            leaf("s/site/wing/south", "coverage", &["r3"], 1, 0),
            leaf("s/air", "patrol", &[], 0, 0),
        ];
        assert_eq!(
            team_tree(&m),
            "teams of s:\n  site\n    wing\n      north (patrol, min 1): r1, r2; 7 barriers passed\n      south (coverage): r3; 1 barriers passed\n  air (patrol): no members; 0 barriers passed\n"
        );
    }
}
