//! Every Rerun entity path of the fleet view, built here only.
//!
//! | path | archetype | what |
//! |---|---|---|
//! | `fleet/map/<name>` | Image (grid map, rows from the bottom, placed in metres) or LineStrips2D + Points2D (graph map: lanes, vertices) | a mission's map, logged once (static) |
//! | `fleet/map/<name>/chargers` | Points2D | a graph map's chargers (Open-RMF's `is_charger`), named, static |
//! | `fleet/robots/<id>` | Points2D | robot position, coloured by mission, labelled `id · mission/type` |
//! | `fleet/robots/<id>/heading` | Arrows2D | heading |
//! | `fleet/robots/<id>/trail` | LineStrips2D | last positions |
//! | `fleet/missions/<name>/tour` | LineStrips2D | closed patrol tour |
//! | `fleet/missions/<name>/waypoints` | Points2D | patrol waypoints |
//! | `fleet/missions/<name>/points` | Points2D | coverage points |
//! | `fleet/missions/<name>/region` | LineStrips2D | coverage region: outer ring and holes |
//! | `fleet/traffic/<id>/held` | LineStrips2D | lanes the robot holds in traffic (graph maps), its colour |
//! | `fleet/traffic/<id>/ahead` | LineStrips2D | the rest of its route, thin |
//! | `fleet/traffic/<id>/waits` | Arrows2D | to each robot in its way while it waits (red: blocked), labelled |
//! | `metrics/traffic/waiting` | Scalars | robots standing waiting for traffic, all maps |
//! | `batteries/robots/<id>` | Scalars | the robot's battery charge, percent |
//! | `batteries/all` | BarChart | every robot's charge, percent, in id order (at most once a second) |
//! | `events/teams` | TextLog | team membership changes |
//! | `events/sync` | TextLog | barrier arrivals |
//! | `advice` | TextLog | advising agent, level = priority |
//! | `metrics/<name>/worst_idleness`, `…/avg_idleness` | Scalars | patrol idleness, robot seconds |
//! | `metrics/<name>/coordination_msgs_per_s` | Scalars | plan + sync messages per second |
//!
//! Timeline: `fleet_time`, seconds since the bridge started.

/// The one timeline.
pub const TIMELINE: &str = "fleet_time";
pub const TEAMS_LOG: &str = "events/teams";
pub const SYNC_LOG: &str = "events/sync";
pub const ADVICE_LOG: &str = "advice";

/// Where the blueprint's fleet view is rooted.
pub const FLEET: &str = "fleet";
pub const EVENTS: &str = "events";
pub const METRICS: &str = "metrics";

pub fn map(name: &str) -> String {
    format!("fleet/map/{name}")
}
pub fn map_vertices(name: &str) -> String {
    format!("fleet/map/{name}/vertices")
}
pub fn map_chargers(name: &str) -> String {
    format!("fleet/map/{name}/chargers")
}
pub fn robot(id: &str) -> String {
    format!("fleet/robots/{id}")
}
pub fn robot_heading(id: &str) -> String {
    format!("fleet/robots/{id}/heading")
}
pub fn robot_trail(id: &str) -> String {
    format!("fleet/robots/{id}/trail")
}
pub fn traffic(id: &str) -> String {
    format!("fleet/traffic/{id}")
}
pub fn traffic_held(id: &str) -> String {
    format!("fleet/traffic/{id}/held")
}
pub fn traffic_ahead(id: &str) -> String {
    format!("fleet/traffic/{id}/ahead")
}
pub fn traffic_waits(id: &str) -> String {
    format!("fleet/traffic/{id}/waits")
}
pub const TRAFFIC_WAITING: &str = "metrics/traffic/waiting";
/// Where the batteries' views are rooted.
pub const BATTERY_ROOT: &str = "batteries";
pub const BATTERIES: &str = "batteries/all";
pub fn battery(id: &str) -> String {
    format!("batteries/robots/{id}")
}
pub fn mission_tour(name: &str) -> String {
    format!("fleet/missions/{name}/tour")
}
pub fn mission_waypoints(name: &str) -> String {
    format!("fleet/missions/{name}/waypoints")
}
pub fn mission_points(name: &str) -> String {
    format!("fleet/missions/{name}/points")
}
pub fn mission_region(name: &str) -> String {
    format!("fleet/missions/{name}/region")
}
pub fn metric(name: &str, metric: &str) -> String {
    format!("metrics/{name}/{metric}")
}
