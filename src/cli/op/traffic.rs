//! `mrmm op traffic [MAP]`: what central's traffic authority holds on each map with lanes — every
//! robot's route, how far it got and may go, the vertices it holds, whom it waits for and for how
//! long, and whether it is blocked (`mrmm/system/traffic`); `--clear ROBOT` takes a lost robot
//! off the lanes.

use mrmm_net::client::Client;
use mrmm_proto::traffic::TrafficView;
use mrmm_proto::{self as proto, MapInfo};
use serde_json::Value;

/// Prints traffic on every map with lanes, or on `map` only (a map's name, or the start of its hash).
pub async fn exec(client: &Client, map: Option<String>, json: bool) -> anyhow::Result<()> {
    let none = None::<&()>;
    let v: Value = client.query(proto::Key::SystemTraffic, none).await?;
    let maps: Vec<MapInfo> = client.query(proto::Key::SystemMaps, none).await.unwrap_or_default();
    let name_of = |hash: &str| maps.iter().find(|m| m.hash == hash).map_or_else(|| hash[..12.min(hash.len())].to_string(), |m| m.name.clone());
    let mut views: Vec<TrafficView> = serde_json::from_value(v)?;
    if let Some(m) = &map {
        views.retain(|v| name_of(&v.map) == *m || v.map.starts_with(m.as_str()));
        anyhow::ensure!(!views.is_empty(), "no traffic on a map {m:?} (maps with lanes: see `mrmm op maps`)");
    }
    if json {
        return super::print_json(&serde_json::to_value(&views)?);
    }
    print!("{}", table(&views, name_of));
    Ok(())
}

/// Takes lost robot `robot` off the lanes and says what was freed.
pub async fn clear(client: &Client, robot: &str, json: bool) -> anyhow::Result<()> {
    let req = mrmm_proto::traffic::TrafficClear { robot: robot.into() };
    let v: Value = client.query(proto::Key::SystemCmd(proto::SystemCmd::ClearTraffic), Some(&req)).await?;
    if json {
        return super::print_json(&v);
    }
    let done: mrmm_proto::traffic::TrafficCleared = serde_json::from_value(v)?;
    println!("{} taken off the lanes: {} vertices freed on {} map(s)", done.robot, done.vertices, done.maps.len());
    Ok(())
}

/// Traffic as a table per map.
pub fn table(views: &[TrafficView], name_of: impl Fn(&str) -> String) -> String {
    if views.is_empty() {
        return "no map has robots in traffic\n".into();
    }
    let mut out = String::new();
    for v in views {
        out.push_str(&format!("map {}  authority incarnation {}  deputies {}\n", name_of(&v.map), v.incarnation, list(&v.deputies)));
        let rows: Vec<Vec<String>> = v
            .robots
            .iter()
            .map(|r| {
                let pos = |p: Option<u32>| p.map_or_else(|| "-".to_string(), |p| format!("{p}"));
                let state = if r.lost {
                    "lost".to_string()
                } else if !r.blocked.is_empty() {
                    "BLOCKED".to_string()
                } else if r.waiting_s.is_some() {
                    "waiting".to_string()
                } else if r.docked {
                    "docked".to_string()
                } else if r.reached.is_some_and(|p| p as usize + 1 == r.route.len()) {
                    "arrived".to_string()
                } else {
                    "driving".to_string()
                };
                vec![
                    r.robot.to_string(),
                    state,
                    format!("{}/{}", pos(r.reached), r.route.len()),
                    pos(r.granted),
                    route(&r.route),
                    format!("{:?}", r.holds),
                    list(if r.blocked.is_empty() { &r.waits_for } else { &r.blocked }),
                    r.waiting_s.map_or_else(|| "-".into(), |w| format!("{w:.0} s")),
                ]
            })
            .collect();
        out.push_str(&super::super::table::render(&["robot", "state", "reached", "granted", "route", "holds", "waits for", "since"], &rows));
        out.push('\n');
    }
    out
}

fn list(ids: &[proto::RobotId]) -> String {
    if ids.is_empty() {
        return "-".into();
    }
    ids.iter().map(proto::RobotId::as_str).collect::<Vec<_>>().join(",")
}

/// A route's vertices, elided in the middle when long.
fn route(r: &[u32]) -> String {
    let show = |vs: &[u32]| vs.iter().map(u32::to_string).collect::<Vec<_>>().join("→");
    if r.len() <= 8 {
        return show(r);
    }
    format!("{}→…→{}", show(&r[..4]), show(&r[r.len() - 3..]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::traffic::TrafficRobotView;

    #[test]
    fn the_table_says_who_waits_for_whom() {
        let r = |id: &str, waits: &[&str], blocked: bool| TrafficRobotView {
            robot: id.into(),
            route: (0..12).collect(),
            points: vec![],
            reached: Some(2),
            granted: Some(3),
            holds: vec![2, 3],
            waits_for: waits.iter().map(|w| (*w).into()).collect(),
            waiting_s: (!waits.is_empty()).then_some(12.4),
            blocked: if blocked { waits.iter().map(|w| (*w).into()).collect() } else { vec![] },
            lost: false,
            docked: false,
        };
        let v = TrafficView {
            map: "ab".repeat(32),
            incarnation: 7,
            deputies: vec!["r1".into(), "r2".into()],
            robots: vec![r("r1", &[], false), r("r2", &["r1"], true)],
        };
        let t = table(&[v], |_| "office".into());
        assert!(t.contains("map office  authority incarnation 7  deputies r1,r2"), "{t}");
        assert!(t.lines().any(|l| l.starts_with("r2") && l.contains("BLOCKED") && l.contains("r1") && l.contains("12 s")), "{t}");
        assert!(t.contains("0→1→2→3→…→9→10→11"), "{t}");
    }
}
