//! Traffic on a graph map, on the wire: what a robot tells its map's traffic authority
//! ([`TrafficReport`], on `mrmm/traffic/<map hash>/report/<id>`) and what the authority tells it
//! ([`TrafficOrder`], on `mrmm/traffic/<map hash>/order/<id>`). A robot reports where it wants to
//! go and what it holds whenever either changes and every [`REPORT_S`]; the authority answers
//! every report with the robot's current order. Both are JSON, sealed: a robot speaks only for
//! itself, orders come from central — or, while central is away, from a deputy robot its orders
//! named. docs/traffic.md tells the whole protocol.

use serde::{Deserialize, Serialize};

use crate::RobotId;

/// Seconds between two reports of a robot on a graph map (it also reports at every change).
pub const REPORT_S: f64 = 1.0;
/// A robot that heard no order for this long (seconds) starts no new hop: it stops at the end of
/// the lane it drives.
pub const QUIET_S: f64 = 3.0;
/// Robots named to follow a map's traffic authority and take over from it, at most.
pub const DEPUTIES: usize = 2;
/// Incarnations a deputy's order may be above the highest of central's that a robot heard: a
/// deputy takes over as one above what it followed, so a handful of takeovers in a row fit,
/// and a deputy cannot outbid central's next start (which counts in milliseconds).
pub const DEPUTY_STEPS: u64 = 16;
/// Vertices of a route at most, in a report or an order.
pub const MAX_ROUTE: usize = 10_000;
/// Bytes of a report or an order at most.
pub const MAX_MESSAGE: usize = 1 << 20;

/// Where a robot goes: the plan's point it navigates to, numbered (a new number: a new goal).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrafficGoal {
    pub id: u64,
    pub x: f64,
    pub y: f64,
}

/// The order a robot drives by, as it holds it: the route's vertices, how far it got and how
/// far it may go (positions in `route`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficHeld {
    /// The authority that gave it ([`TrafficOrder::Route`]'s `incarnation`) and its version.
    pub incarnation: u64,
    pub version: u64,
    pub route: Vec<u32>,
    /// The position it last reached (none: not on the graph yet).
    pub reached: Option<u32>,
    /// The position it may drive to (none: not even its entry).
    pub upto: Option<u32>,
}

/// What a robot tells its map's traffic authority.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficReport {
    pub robot: RobotId,
    /// Increases with every report (older ones arriving late are dropped).
    pub seq: u64,
    /// Where the robot is (map frame).
    pub x: f64,
    pub y: f64,
    /// Where it goes; none: it stands where it is.
    pub goal: Option<TrafficGoal>,
    /// The order it drives by.
    pub held: Option<TrafficHeld>,
    /// It stands charging at a charger: a parking spot it does not leave to make way (others are
    /// routed round it where they can be).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub docked: bool,
}

/// A vertex of a route, with where it is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RouteVertex {
    pub v: u32,
    pub x: f64,
    pub y: f64,
    /// Its name on the map, where the map gives it one that names it alone
    /// ([`RouteVertex::may_name`]): what a VDA 5050 vehicle knows the node by.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// How far along the lane to the route's next vertex the robot must be for this vertex to
    /// be let go, metres (none: not before the next vertex). A robot reports as it passes it, so
    /// that the robot behind closes up at once rather than at its next periodic report; the
    /// authority checks the reported position itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub release: Option<f64>,
}

/// The longest vertex name a route carries (a longer one: the vertex goes by its index).
pub const MAX_VERTEX_NAME: usize = 64;

impl RouteVertex {
    /// Vertex `v` at (`x`, `y`), without a name.
    pub fn at(v: u32, x: f64, y: f64) -> RouteVertex {
        RouteVertex { v, x, y, name: None, release: None }
    }

    /// What the vertex is called as a node of an order: its name, else `v<index>`.
    pub fn node_id(&self) -> String {
        self.name.clone().unwrap_or_else(|| format!("v{}", self.v))
    }

    /// Whether `name`, given to one vertex of a map alone, may name it in routes: not empty, at
    /// most [`MAX_VERTEX_NAME`] bytes, and not `v<digits>` (which names vertices by index).
    pub fn may_name(name: &str) -> bool {
        let by_index = name.strip_prefix('v').is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()));
        !name.is_empty() && name.len() <= MAX_VERTEX_NAME && !by_index
    }
}

/// What the traffic authority tells a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "order", rename_all = "snake_case")]
pub enum TrafficOrder {
    /// The map has no lanes: drive the plan's points as they are.
    Free,
    /// For goal `goal`: drive `route` (which supersedes every order of a lower `(incarnation,
    /// version)`), from position `reached` (as the authority last heard) up to position `upto`.
    /// `deputies`: the robots that follow the authority and take over, in turn, when central
    /// is away ([`DEPUTIES`] at most). `off`: the goal itself, off the lanes, which the robot
    /// drives to straight from the route's last vertex once it stands there with the whole route
    /// granted (and back to that vertex before its next route): given only where no other robot
    /// can come within the clearance of that way while this one holds the vertex.
    Route {
        goal: u64,
        incarnation: u64,
        version: u64,
        route: Vec<RouteVertex>,
        reached: Option<u32>,
        upto: Option<u32>,
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        deputies: Vec<RobotId>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        off: Option<[f64; 2]>,
    },
    /// Goal `goal` cannot be driven to on the map's lanes.
    Refused { goal: u64, why: String },
    /// The operator took this robot off the map's lanes ([`TrafficClear`]) while authority
    /// `incarnation` led: it holds nothing. Its deputies forget it (a takeover must not hand it
    /// back what it held); the robot, should it come back, stops and asks for its way anew.
    Cleared { incarnation: u64 },
}

/// The operator takes a lost robot off the lanes (`mrmm/system/cmd/traffic/clear`, `mrmm op
/// traffic --clear ID`): every vertex and lane it held in traffic is free again. Only a robot
/// whose liveliness went: the operator says it is no longer where it stood.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrafficClear {
    pub robot: RobotId,
}

/// What clearing a robot freed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficCleared {
    pub robot: RobotId,
    /// The maps (bundle hashes) it was in traffic on.
    pub maps: Vec<String>,
    /// The vertices it held there, together.
    pub vertices: usize,
}

/// What the operator sees of traffic on one map (`mrmm/system/traffic`, `mrmm op traffic`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficView {
    /// The map's bundle hash.
    pub map: String,
    /// The authority's incarnation.
    pub incarnation: u64,
    /// The deputies its orders name.
    pub deputies: Vec<RobotId>,
    /// Every robot in traffic on the map, by id.
    pub robots: Vec<TrafficRobotView>,
}

/// One robot in traffic, as the authority holds it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrafficRobotView {
    pub robot: RobotId,
    /// Its route's vertices (the map's vertex indices; vertices past the map's own cut its long
    /// lanes into segments, in the order `traffic::layout::segmented` adds them).
    pub route: Vec<u32>,
    /// Where each vertex of `route` is, metres.
    #[serde(default)]
    pub points: Vec<[f64; 2]>,
    /// The position in `route` it last reached, and the one it may drive to.
    pub reached: Option<u32>,
    pub granted: Option<u32>,
    /// The vertices it holds (those of lanes it drives, and where it stands).
    pub holds: Vec<u32>,
    /// Robots in the way of its next lane while it stands waiting, and for how long it waited
    /// (seconds).
    pub waits_for: Vec<RobotId>,
    pub waiting_s: Option<f64>,
    /// Robots it waits for with no way found around them (reported `Blocked`).
    pub blocked: Vec<RobotId>,
    /// Its liveliness went: it keeps what it held.
    pub lost: bool,
    /// It stands charging at a charger: it does not make way.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub docked: bool,
}

impl TrafficReport {
    /// Checks what a robot may not send: non-finite positions, routes longer than [`MAX_ROUTE`],
    /// positions beyond the route.
    pub fn check(&self) -> Result<(), String> {
        if !(self.x.is_finite() && self.y.is_finite()) {
            return Err("position is not finite".into());
        }
        if let Some(g) = &self.goal {
            if !(g.x.is_finite() && g.y.is_finite()) {
                return Err("goal is not finite".into());
            }
        }
        if let Some(h) = &self.held {
            if h.route.len() > MAX_ROUTE {
                return Err(format!("route of {} vertices (at most {MAX_ROUTE})", h.route.len()));
            }
            let n = h.route.len() as u32;
            if h.reached.is_some_and(|r| r >= n) || h.upto.is_some_and(|u| u >= n) || h.reached > h.upto {
                return Err(format!("positions reached {:?}, upto {:?} do not fit a route of {n} vertices", h.reached, h.upto));
            }
        }
        Ok(())
    }
}

impl TrafficOrder {
    /// Checks what the authority may not send: routes too long, positions beyond them, points
    /// not finite.
    pub fn check(&self) -> Result<(), String> {
        let Self::Route { route, reached, upto, deputies, off, .. } = self else { return Ok(()) };
        if off.is_some_and(|[x, y]| !(x.is_finite() && y.is_finite())) {
            return Err("the point off the lanes is not finite".into());
        }
        if deputies.len() > DEPUTIES {
            return Err(format!("{} deputies (at most {DEPUTIES})", deputies.len()));
        }
        if route.is_empty() || route.len() > MAX_ROUTE {
            return Err(format!("route of {} vertices (1 to {MAX_ROUTE})", route.len()));
        }
        if route.iter().any(|v| !(v.x.is_finite() && v.y.is_finite())) {
            return Err("a vertex is not finite".into());
        }
        let n = route.len() as u32;
        if reached.is_some_and(|r| r >= n) || upto.is_some_and(|u| u >= n) || *reached > *upto {
            return Err(format!("positions reached {reached:?}, upto {upto:?} do not fit a route of {n} vertices"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_and_orders_that_do_not_fit_are_refused() {
        let held = TrafficHeld { incarnation: 1, version: 1, route: vec![1, 2, 3], reached: Some(0), upto: Some(2) };
        let mut r =
            TrafficReport { robot: "r1".into(), seq: 1, x: 0.0, y: 0.0, goal: Some(TrafficGoal { id: 1, x: 1.0, y: 1.0 }), held: Some(held), docked: false };
        assert_eq!(r.check(), Ok(()));
        if let Some(h) = r.held.as_mut() {
            h.upto = Some(3);
        }
        assert!(r.check().is_err());
        if let Some(h) = r.held.as_mut() {
            (h.upto, h.reached) = (Some(0), Some(1));
        }
        assert!(r.check().is_err(), "reached beyond what was granted");
        r.held = None;
        r.x = f64::NAN;
        assert!(r.check().is_err());
        let o = TrafficOrder::Route { goal: 1, incarnation: 1, version: 1, route: vec![], reached: None, upto: None, deputies: vec![], off: None };
        assert!(o.check().is_err());
        let json = serde_json::to_string(&TrafficOrder::Free).expect("json");
        assert_eq!(json, r#"{"order":"free"}"#);
    }
}
