//! A VDA 5050 vehicle as the robot's body, without I/O: every goal the robot drives to becomes
//! an order (or an update of the one it drives, stitched at its last base node), a stop is a
//! `cancelOrder`, and the vehicle's `state` says where it is, how fast it goes, its battery, and
//! whether it passed the goal's node. The messages go out through [`VdaDrive::take`]; the gateway
//! adds their headers and publishes them.

use mrmm_proto::{BatteryState, Pose, Velocity};
use mrmm_vda5050::{instant, Action, BlockingType, FromVehicle, Order, OrderBook, State, Visualization, Waypoint};

use crate::body::Limits;

/// What the vehicle must be sent.
#[derive(Debug, Clone, PartialEq)]
pub enum VdaOut {
    Order(Box<Order>),
    Instant(Vec<Action>),
}

/// The goal being driven to: its node.
#[derive(Debug, Clone, PartialEq)]
struct Target {
    node: Waypoint,
}

/// The state of a VDA 5050 body.
#[derive(Debug, Clone)]
pub struct VdaDrive {
    limits: Limits,
    pose: Pose,
    velocity: Velocity,
    battery: Option<BatteryState>,
    book: OrderBook,
    /// The node the vehicle said it passed last.
    last_node: String,
    goal: Option<Target>,
    /// Why the vehicle cannot get to its goal: a FATAL error, or its refusal of an order.
    stuck: Option<String>,
    /// Whether a state was heard (before, the body does not move: orders start where it is).
    heard: bool,
    out: Vec<VdaOut>,
    /// Instant actions sent, and points off the map's vertices named: ids.
    actions: u64,
    points: u64,
    prefix: String,
}

impl VdaDrive {
    /// A vehicle at `start` (until its first state says where it is); order ids begin with
    /// `prefix` (unique per gateway start), nodes are on map `map_id`.
    pub fn new(start: Pose, limits: Limits, prefix: &str, map_id: &str) -> VdaDrive {
        VdaDrive {
            limits,
            pose: start,
            velocity: Velocity::default(),
            battery: None,
            book: OrderBook::new(prefix, map_id),
            last_node: String::new(),
            goal: None,
            stuck: None,
            heard: false,
            out: Vec::new(),
            actions: 0,
            points: 0,
            prefix: prefix.to_string(),
        }
    }

    pub fn pose(&self) -> Pose {
        self.pose
    }

    pub fn velocity(&self) -> Velocity {
        self.velocity
    }

    pub fn limits(&self) -> Limits {
        self.limits
    }

    pub fn battery(&self) -> Option<BatteryState> {
        self.battery
    }

    pub fn stuck(&self) -> Option<&str> {
        self.stuck.as_deref()
    }

    /// The goal's position, while the vehicle drives to it.
    pub fn goal(&self) -> Option<(f64, f64)> {
        self.goal.as_ref().map(|t| (t.node.x, t.node.y))
    }

    /// Drives to (`x`, `y`) — the map's vertex `vertex` when it is one (its node id is `v<index>`)
    /// — no faster than `speed`. The vehicle goes on from the goal it drives to, if any (the
    /// update adds to its base; a base once released is not taken back).
    pub fn navigate(&mut self, x: f64, y: f64, vertex: Option<u32>, speed: Option<f64>) {
        if self.goal() == Some((x, y)) {
            return;
        }
        let node_id = match vertex {
            Some(v) => format!("v{v}"),
            None => {
                self.points += 1;
                format!("{}-p{}", self.prefix, self.points)
            }
        };
        let node = Waypoint { node_id, x, y };
        let here = Waypoint {
            node_id: if self.last_node.is_empty() { format!("{}-start", self.prefix) } else { self.last_node.clone() },
            x: self.pose.x,
            y: self.pose.y,
        };
        let speed = speed.map(|s| s.min(self.limits.max_speed));
        let order = self.book.release(&here, std::slice::from_ref(&node), &[], speed);
        self.out.push(VdaOut::Order(Box::new(order)));
        self.goal = Some(Target { node });
        self.stuck = None;
    }

    /// Stops: the order is cancelled (the vehicle stops at once or at its next node, as it
    /// can), and the next goal is a new order from where it stands.
    pub fn hold(&mut self) {
        if self.goal.take().is_some() || self.book.order_id().is_some() {
            self.actions += 1;
            self.out.push(VdaOut::Instant(vec![instant("cancelOrder", format!("{}-a{}", self.prefix, self.actions), BlockingType::Hard)]));
            self.book.forget();
        }
    }

    /// What the vehicle said (checked by the caller).
    pub fn on_message(&mut self, msg: &FromVehicle) {
        match msg {
            FromVehicle::State(s) => self.on_state(s),
            FromVehicle::Visualization(v) => self.on_visualization(v),
        }
    }

    /// Where the vehicle is and how fast it goes, between two states.
    pub fn on_visualization(&mut self, vis: &Visualization) {
        if let Some(p) = &vis.agv_position {
            self.pose = Pose { x: p.x, y: p.y, theta: p.theta };
        }
        if let Some(v) = &vis.velocity {
            let (vx, vy) = (v.vx.unwrap_or(0.0), v.vy.unwrap_or(0.0));
            self.velocity = Velocity { v: vx.hypot(vy), omega: v.omega.unwrap_or(0.0) };
        }
    }

    /// The vehicle's state (checked by the caller).
    pub fn on_state(&mut self, state: &State) {
        self.heard = true;
        self.on_visualization(&Visualization { agv_position: state.agv_position.clone(), velocity: state.velocity.clone(), ..Visualization::default() });
        if state.velocity.is_none() && !state.driving {
            self.velocity = Velocity::default();
        }
        if let Some(b) = &state.battery_state {
            self.battery = Some(BatteryState { charge: b.battery_charge / 100.0, charging: b.charging, reach_m: b.reach });
        }
        if !state.last_node_id.is_empty() {
            self.last_node.clone_from(&state.last_node_id);
        }
        self.book.observe(state);
        if self.goal.is_some() && self.book.base_done(state) && !state.driving {
            self.goal = None;
        }
        self.stuck = state.fatal().or_else(|| state.order_refused()).filter(|_| self.goal.is_some());
        if self.book.order_id().is_none() && self.goal.is_some() {
            // The vehicle dropped our order (restarted, or took another): the goal is given again
            // as a new order from where it stands.
            if let Some(t) = self.goal.take() {
                self.navigate(t.node.x, t.node.y, t.node.node_id.strip_prefix('v').and_then(|n| n.parse().ok()), None);
            }
        }
    }

    /// The messages to send, oldest first.
    pub fn take(&mut self) -> Vec<VdaOut> {
        std::mem::take(&mut self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_vda5050::msg::AgvPosition;

    fn drive() -> VdaDrive {
        VdaDrive::new(Pose { x: 0.0, y: 0.0, theta: 0.0 }, Limits { max_speed: 1.0, max_turn_rate: 1.0 }, "gw", "m")
    }

    fn state(order: &str, last: &str, seq: u64, driving: bool, x: f64) -> State {
        State {
            order_id: order.into(),
            last_node_id: last.into(),
            last_node_sequence_id: seq,
            driving,
            agv_position: Some(AgvPosition { x, y: 0.0, theta: 0.0, map_id: "m".into(), position_initialized: true }),
            ..State::default()
        }
    }

    fn orders(out: Vec<VdaOut>) -> Vec<(String, u64, Vec<String>)> {
        out.into_iter()
            .filter_map(|o| match o {
                VdaOut::Order(o) => Some((o.order_id, o.order_update_id, o.nodes.into_iter().map(|n| n.node_id).collect())),
                VdaOut::Instant(_) => None,
            })
            .collect()
    }

    #[test]
    fn goals_become_an_order_then_updates_stitched_at_the_node_reached() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate(1.0, 0.0, Some(1), Some(5.0));
        assert_eq!(orders(d.take()), [("gw-1".to_string(), 0, vec!["v0".to_string(), "v1".to_string()])]);
        d.on_state(&state("gw-1", "v0", 0, true, 0.5));
        assert_eq!(d.goal(), Some((1.0, 0.0)), "still driving");
        d.on_state(&state("gw-1", "v1", 2, false, 1.0));
        assert_eq!(d.goal(), None, "the goal's node passed and the vehicle stopped: idle");
        d.navigate(2.0, 0.0, Some(2), None);
        assert_eq!(orders(d.take()), [("gw-1".to_string(), 1, vec!["v1".to_string(), "v2".to_string()])]);
    }

    #[test]
    fn a_stop_cancels_the_order_and_the_next_goal_is_a_new_order_from_where_the_vehicle_is() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate(1.0, 0.0, Some(1), None);
        d.hold();
        let out = d.take();
        assert!(matches!(&out[1], VdaOut::Instant(a) if a[0].action_type == "cancelOrder"), "{out:?}");
        assert!(d.goal().is_none());
        d.on_state(&state("gw-1", "v0", 0, false, 0.4));
        d.navigate(3.0, 0.0, None, None);
        let o = orders(d.take());
        assert_eq!(o[0].0, "gw-2");
        assert_eq!(o[0].2[0], "v0", "a new order starts at the vehicle's last node");
    }

    #[test]
    fn a_vehicle_that_drops_the_order_is_given_the_goal_again_and_its_refusal_is_reported() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate(1.0, 0.0, Some(1), None);
        d.take();
        d.on_state(&state("theirs", "v0", 0, false, 0.0));
        let o = orders(d.take());
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!((o[0].0.as_str(), o[0].2[1].as_str()), ("gw-2", "v1"));
        let mut s = state("gw-2", "v0", 0, false, 0.0);
        s.errors.push(mrmm_vda5050::msg::VehicleError {
            error_type: "noRouteError".into(),
            error_level: "WARNING".into(),
            error_description: Some("blocked".into()),
        });
        d.on_state(&s);
        assert_eq!(d.stuck(), Some("noRouteError: blocked"));
    }
}
