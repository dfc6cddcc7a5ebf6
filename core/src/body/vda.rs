//! A VDA 5050 vehicle as the robot's body, without I/O: what the robot drives to becomes an
//! order (or an update of the one the vehicle drives, stitched at its last base node). On lanes,
//! the **base** released is exactly what traffic granted (the goal vertex and the granted ones
//! after it) and the rest of the route is the **horizon**, so the vehicle drives on through a
//! grant without stopping at each vertex, and stops at the grant's end if no more is granted. A
//! way off the released base is a `cancelOrder` (a new order waits until the vehicle says it
//! ended). A hold (a mission paused, a new plan, traffic's halt) that lasts to the end of the
//! tick, of a vehicle with released nodes still ahead, is a `startPause`: it stops where it is and
//! keeps its order; the next goal resumes it (`stopPause`, once the vehicle said it paused). The
//! vehicle's `state` says where it is, how fast it goes, its battery, and which released node it
//! passed last. The messages go out through [`VdaDrive::take`]; the gateway adds their headers.

use std::collections::VecDeque;

use mrmm_proto::traffic::RouteVertex;
use mrmm_proto::{BatteryState, Pose, VehicleState, Velocity, MAX_VEHICLE_ITEMS, MAX_VEHICLE_TEXT, MAX_VEHICLE_WORD};
use mrmm_vda5050::{instant, Action, BlockingType, FromVehicle, Order, OrderBook, State, Visualization, Waypoint};

use crate::body::Limits;

/// What the vehicle must be sent.
#[derive(Debug, Clone, PartialEq)]
pub enum VdaOut {
    Order(Box<Order>),
    Instant(Vec<Action>),
}

/// What the robot drives to: its node, the nodes it may drive on through (granted), and those
/// it is expected to drive to after them (the horizon).
#[derive(Debug, Clone, PartialEq)]
struct Target {
    want: Vec<Waypoint>,
    horizon: Vec<Waypoint>,
    speed: Option<f64>,
    /// The vehicle passed the goal's node (it is reached once the vehicle drives on, or stands).
    passed: bool,
}

impl Target {
    fn node(&self) -> &Waypoint {
        &self.want[0]
    }
}

/// Nodes passed that the body remembers (to know a goal it is given was passed already).
const BEHIND: usize = 16;

/// A node released to the vehicle that it has not passed yet.
#[derive(Debug, Clone, PartialEq)]
struct Released {
    node: Waypoint,
    seq: u64,
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
    /// The base released and not yet passed, in order.
    ahead: VecDeque<Released>,
    /// The nodes of the base the vehicle passed since its order began, the last ones, oldest
    /// first.
    behind: VecDeque<String>,
    /// Why the vehicle cannot get to its goal: a FATAL error, or its refusal of an order.
    stuck: Option<String>,
    out: Vec<VdaOut>,
    /// A `cancelOrder` sent and not yet ended (its action id): a new order waits for it (a
    /// vehicle refuses a new order while it still has one).
    cancelling: Option<String>,
    /// A `startPause` sent and no `stopPause` since.
    paused: bool,
    /// A hold not yet carried out: at the end of the tick (`take`) it pauses the vehicle, unless
    /// a goal came after it in the same tick (a new plan's first goal).
    pause_due: bool,
    /// A `startPause` sent that the vehicle has not yet said ended (its action id): a vehicle
    /// refuses `stopPause` (and a robot may not change its order) until it is paused.
    pausing: Option<String>,
    /// A `stopPause` sent that the vehicle has not yet said ended: a vehicle may refuse a
    /// `startPause` until it is driving again.
    unpausing: Option<String>,
    /// What the vehicle's last state said of it beyond pose, speed and battery.
    said: Option<VehicleState>,
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
            ahead: VecDeque::new(),
            behind: VecDeque::new(),
            stuck: None,
            out: Vec::new(),
            cancelling: None,
            paused: false,
            pause_due: false,
            pausing: None,
            unpausing: None,
            said: None,
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

    /// What the vehicle's last state said of it beyond pose, speed and battery (its last node,
    /// errors, actions), cut to what telemetry carries.
    pub fn said(&self) -> Option<&VehicleState> {
        self.said.as_ref()
    }

    /// The goal's position, until the vehicle passed its node.
    pub fn goal(&self) -> Option<(f64, f64)> {
        self.goal.as_ref().map(|t| (t.node().x, t.node().y))
    }

    /// Drives to (`x`, `y`), a point off the lanes, no faster than `speed`.
    pub fn navigate(&mut self, x: f64, y: f64, speed: Option<f64>) {
        if self.goal() == Some((x, y)) {
            return;
        }
        self.points += 1;
        let node = Waypoint { node_id: format!("{}-p{}", self.prefix, self.points), x, y };
        self.drive(Target { want: vec![node], horizon: Vec::new(), speed, passed: false });
    }

    /// Drives to the lanes' vertex `v`, and on through `granted` (traffic granted them too), with
    /// `then` the rest of the route (the horizon); nodes are the vertices' names on the map, else
    /// `v<index>` ([`RouteVertex::node_id`]). Called again as the
    /// grant grows: only what is new is released (an update), nothing is taken back.
    pub fn navigate_lane(&mut self, v: &RouteVertex, granted: &[RouteVertex], then: &[RouteVertex], speed: Option<f64>) {
        let wp = |r: &RouteVertex| Waypoint { node_id: r.node_id(), x: r.x, y: r.y };
        let want: Vec<Waypoint> = std::iter::once(v).chain(granted).map(wp).collect();
        let target = Target { want, horizon: then.iter().map(wp).collect(), speed, passed: false };
        if self.goal.as_ref().is_some_and(|g| g.want == target.want && g.speed == target.speed) {
            return;
        }
        self.drive(target);
    }

    fn drive(&mut self, mut target: Target) {
        self.pause_due = false;
        match &self.goal {
            Some(g) if g.node() == target.node() => target.passed = g.passed,
            _ => self.stuck = None,
        }
        // Passed already: the vehicle drove on through its grant faster than the robot asked.
        if self.passed_through(&target.want) {
            self.goal = None;
            return;
        }
        self.goal = Some(target);
        if self.cancelling.is_none() {
            self.release();
        }
    }

    /// Releases what the goal wants and the vehicle was not given yet: a new order where it
    /// stands, or an update stitched at the last base node. A goal off the base released (the
    /// way changed) cancels the order first.
    fn release(&mut self) {
        if self.pausing.is_some() || self.unpausing.is_some() {
            return; // once the vehicle says it paused, or drives again (`on_state`)
        }
        let Some(t) = self.goal.clone() else { return };
        let k = self.ahead.len();
        if !self.ahead_leads(&t.want) {
            self.cancel();
            return;
        }
        if self.paused {
            // The way goes on as released: the vehicle drives on.
            self.paused = false;
            let id = self.action_id();
            self.out.push(VdaOut::Instant(vec![instant("stopPause", id.clone(), BlockingType::Hard)]));
            self.unpausing = Some(id);
        }
        if k == t.want.len() {
            return;
        }
        let here = Waypoint {
            node_id: if self.last_node.is_empty() { format!("{}-start", self.prefix) } else { self.last_node.clone() },
            x: self.pose.x,
            y: self.pose.y,
        };
        let speed = t.speed.map(|s| s.min(self.limits.max_speed));
        let order = self.book.release(&here, &t.want[k..], &t.horizon, speed);
        // The first node is where the vehicle stands (a new order) or the last base node, which
        // it has already (an update).
        for n in order.nodes.iter().skip(1).filter(|n| n.released) {
            let (x, y) = n.node_position.as_ref().map_or((0.0, 0.0), |p| (p.x, p.y));
            self.ahead.push_back(Released { node: Waypoint { node_id: n.node_id.clone(), x, y }, seq: n.sequence_id });
        }
        self.out.push(VdaOut::Order(Box::new(order)));
    }

    /// Whether the vehicle passed the start of `want` (its last passed nodes are that start) and
    /// the base it has ahead goes on as `want` does.
    fn passed_through(&self, want: &[Waypoint]) -> bool {
        (1..=want.len().min(self.behind.len())).any(|j| {
            let tail = self.behind.iter().skip(self.behind.len() - j);
            tail.zip(&want[..j]).all(|(b, w)| *b == w.node_id) && self.ahead_leads(&want[j..])
        })
    }

    /// Whether the base released and not passed is the start of `want`.
    fn ahead_leads(&self, want: &[Waypoint]) -> bool {
        self.ahead.len() <= want.len() && self.ahead.iter().zip(want).all(|(r, w)| r.node.node_id == w.node_id)
    }

    fn action_id(&mut self) -> String {
        self.actions += 1;
        format!("{}-a{}", self.prefix, self.actions)
    }

    /// Cancels the order (a pause is ended with the next order, if the vehicle is still paused
    /// once the cancel ended).
    fn cancel(&mut self) {
        let id = self.action_id();
        self.out.push(VdaOut::Instant(vec![instant("cancelOrder", id.clone(), BlockingType::Hard)]));
        self.cancelling = Some(id);
        self.book.forget();
        self.ahead.clear();
        self.behind.clear();
    }

    /// Stops where it is: a vehicle with released nodes still ahead is paused (it keeps its
    /// order); one that stands at the end of its base already is left as it is. The next goal
    /// resumes it.
    pub fn hold(&mut self) {
        self.goal = None;
        self.pause_due = true;
    }

    /// A hold that lasted to the end of the tick pauses a vehicle that has released nodes ahead.
    fn pause_if_due(&mut self) {
        if self.unpausing.is_some() {
            return; // the hold waits for the vehicle to say it drives again
        }
        if std::mem::take(&mut self.pause_due) && !self.ahead.is_empty() && !self.paused && self.cancelling.is_none() && self.pausing.is_none() {
            self.paused = true;
            let id = self.action_id();
            self.out.push(VdaOut::Instant(vec![instant("startPause", id.clone(), BlockingType::Hard)]));
            self.pausing = Some(id);
        }
    }

    /// Starts charging where it stands (it holds first), or stops: `startCharging` or
    /// `stopCharging`. Its state says whether it charges.
    pub fn charge(&mut self, on: bool) {
        if on {
            self.hold();
            self.pause_if_due();
        }
        let id = self.action_id();
        self.out.push(VdaOut::Instant(vec![instant(if on { "startCharging" } else { "stopCharging" }, id, BlockingType::Hard)]));
    }

    /// Whether the vehicle was told to pause and not yet to go on.
    pub fn paused(&self) -> bool {
        self.paused
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
        self.said = Some(summary(state));
        // Paused or not, as the vehicle says (unless a pause or its end is on its way).
        if let (None, None, Some(p)) = (&self.pausing, &self.unpausing, state.paused) {
            self.paused = p;
        }
        // The pause (or its end) came about, or failed; what waited goes out.
        if let Some(done) = action_ended(state, &self.pausing) {
            self.paused = done;
            self.pausing = None;
            if self.cancelling.is_none() {
                self.release();
            }
        }
        if action_ended(state, &self.unpausing).is_some() {
            self.unpausing = None;
            self.paused = state.paused.unwrap_or(false);
            if self.cancelling.is_none() {
                self.release();
            }
        }
        // The cancel ended (finished, or failed: the vehicle had no order to cancel).
        if action_ended(state, &self.cancelling).is_some() {
            self.cancelling = None;
            self.release();
        }
        self.follow(state);
        self.stuck = state.fatal().or_else(|| state.order_refused()).filter(|_| self.goal.is_some());
        if self.book.order_id().is_none() && self.goal.is_some() && self.cancelling.is_none() {
            // The vehicle dropped our order (someone else gave it one): the goal is given again
            // as a new order from where it stands.
            self.ahead.clear();
            self.behind.clear();
            self.release();
        }
    }

    /// Follows the vehicle along the base released: the nodes it passed leave `ahead`; the goal
    /// is reached once its node is passed (and, at the base's end, the vehicle stands).
    fn follow(&mut self, state: &State) {
        self.book.observe(state);
        if self.book.order_id() != Some(state.order_id.as_str()) {
            return;
        }
        while self.ahead.front().is_some_and(|r| r.seq <= state.last_node_sequence_id) {
            let Some(r) = self.ahead.pop_front() else { break };
            if let Some(g) = self.goal.as_mut().filter(|g| g.want[0].node_id == r.node.node_id) {
                g.passed = true;
            }
            self.behind.push_back(r.node.node_id);
            if self.behind.len() > BEHIND {
                self.behind.pop_front();
            }
        }
        if self.goal.as_ref().is_some_and(|g| g.passed) && (!self.ahead.is_empty() || !state.driving) {
            self.goal = None;
        }
    }

    /// Whether the vehicle passed the lanes' vertex `v` lately (since its order began).
    pub fn passed(&self, v: &RouteVertex) -> bool {
        let id = v.node_id();
        self.behind.contains(&id)
    }

    /// The messages to send, oldest first.
    pub fn take(&mut self) -> Vec<VdaOut> {
        self.pause_if_due();
        std::mem::take(&mut self.out)
    }
}

/// What a vehicle's state says of it beyond pose, speed and battery, cut to what telemetry
/// carries: FATAL errors first, actions not yet ended first.
fn summary(state: &State) -> VehicleState {
    let word = |s: &str| s.chars().take(MAX_VEHICLE_WORD).collect::<String>();
    let mut errors: Vec<_> = state.errors.iter().collect();
    errors.sort_by_key(|e| e.error_level != "FATAL");
    let mut actions: Vec<_> = state.action_states.iter().collect();
    actions.sort_by_key(|a| matches!(a.action_status.as_str(), "FINISHED" | "FAILED"));
    VehicleState {
        last_node: word(&state.last_node_id),
        driving: state.driving,
        paused: state.paused.unwrap_or(false),
        errors: errors
            .into_iter()
            .take(MAX_VEHICLE_ITEMS)
            .map(|e| mrmm_proto::VehicleError {
                kind: word(&e.error_type),
                level: word(&e.error_level),
                description: e.error_description.as_ref().map(|d| d.chars().take(MAX_VEHICLE_TEXT).collect()),
            })
            .collect(),
        actions: actions
            .into_iter()
            .take(MAX_VEHICLE_ITEMS)
            .map(|a| mrmm_proto::VehicleAction { id: word(&a.action_id), kind: a.action_type.as_deref().map(word), status: word(&a.action_status) })
            .collect(),
    }
}

/// Whether the vehicle's state says instant action `id` ended: `Some(true)` finished,
/// `Some(false)` failed, `None` not yet (or no action awaited).
fn action_ended(state: &State, id: &Option<String>) -> Option<bool> {
    let id = id.as_deref()?;
    state.action_states.iter().find(|a| a.action_id == id && matches!(a.action_status.as_str(), "FINISHED" | "FAILED")).map(|a| a.action_status == "FINISHED")
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_vda5050::msg::AgvPosition;

    fn v(v: u32, x: f64) -> RouteVertex {
        RouteVertex::at(v, x, 0.0)
    }

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
        d.navigate_lane(&v(1, 1.0), &[], &[], Some(5.0));
        assert_eq!(orders(d.take()), [("gw-1".to_string(), 0, vec!["v0".to_string(), "v1".to_string()])]);
        d.on_state(&state("gw-1", "v0", 0, true, 0.5));
        assert_eq!(d.goal(), Some((1.0, 0.0)), "still driving");
        d.on_state(&state("gw-1", "v1", 2, false, 1.0));
        assert_eq!(d.goal(), None, "the goal's node passed and the vehicle stopped: idle");
        d.navigate_lane(&v(2, 2.0), &[], &[], None);
        assert_eq!(orders(d.take()), [("gw-1".to_string(), 1, vec!["v1".to_string(), "v2".to_string()])]);
    }

    fn nodes(out: Vec<VdaOut>) -> Vec<(String, u64, bool)> {
        out.into_iter()
            .flat_map(|o| match o {
                VdaOut::Order(o) => o.nodes.into_iter().map(|n| (n.node_id, n.sequence_id, n.released)).collect(),
                VdaOut::Instant(_) => Vec::new(),
            })
            .collect()
    }

    fn n(id: &str, seq: u64, released: bool) -> (String, u64, bool) {
        (id.to_string(), seq, released)
    }

    #[test]
    fn on_lanes_the_grant_is_the_base_the_route_the_horizon_and_a_growing_grant_an_update() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0), v(4, 4.0)], None);
        assert_eq!(nodes(d.take()), [n("v0", 0, true), n("v1", 2, true), n("v2", 4, true), n("v3", 6, false), n("v4", 8, false)]);
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0), v(4, 4.0)], None);
        assert!(d.take().is_empty(), "the same grant again: nothing to send");
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0), v(3, 3.0)], &[v(4, 4.0)], None);
        assert_eq!(nodes(d.take()), [n("v2", 4, true), n("v3", 6, true), n("v4", 8, false)], "the grant grew: an update stitched at v2");
        // The vehicle passes v1 and drives on: the goal is reached, the vehicle never stopped.
        d.on_state(&state("gw-1", "v1", 2, true, 1.0));
        assert_eq!(d.goal(), None);
        assert!(d.passed(&v(1, 1.0)));
        d.navigate_lane(&v(2, 2.0), &[v(3, 3.0)], &[v(4, 4.0)], None);
        assert!(d.take().is_empty(), "v2 and v3 were released already");
        assert_eq!(d.goal(), Some((2.0, 0.0)));
        // It passes v2 and v3 between two states, and stands at v3, the grant's end.
        d.on_state(&state("gw-1", "v3", 6, false, 3.0));
        assert_eq!(d.goal(), None, "v2 passed");
        d.navigate_lane(&v(3, 3.0), &[], &[v(4, 4.0)], None);
        assert_eq!(d.goal(), None, "v3 passed already");
        assert!(d.take().is_empty());
        d.navigate_lane(&v(4, 4.0), &[], &[], None);
        assert_eq!(nodes(d.take()), [n("v3", 6, true), n("v4", 8, true)]);
    }

    /// What the vehicle's state says goes to telemetry cut to its bounds: FATAL errors first,
    /// actions not yet ended first, no more than telemetry carries.
    #[test]
    fn the_vehicles_own_word_is_kept_within_telemetrys_bounds() {
        use mrmm_vda5050::msg::{ActionState, VehicleError};
        let mut d = drive();
        let mut s = state("gw-1", "pantry", 2, true, 1.0);
        s.paused = Some(true);
        let error = |level: &str, text: String| VehicleError { error_type: "noRouteError".into(), error_level: level.into(), error_description: Some(text) };
        s.errors = (0..20).map(|_| error("WARNING", "w".into())).chain([error("FATAL", "x".repeat(1000))]).collect();
        let action = |id: &str, status: &str| ActionState {
            action_id: id.into(),
            action_type: Some("startPause".into()),
            action_status: status.into(),
            ..Default::default()
        };
        s.action_states = (0..10).map(|i| action(&format!("a{i}"), "FINISHED")).chain([action(&"b".repeat(100), "RUNNING")]).collect();
        d.on_state(&s);
        let said = d.said().expect("said").clone();
        assert_eq!((said.last_node.as_str(), said.driving, said.paused), ("pantry", true, true));
        assert_eq!((said.errors.len(), said.errors[0].level.as_str()), (MAX_VEHICLE_ITEMS, "FATAL"));
        assert_eq!(said.errors[0].description.as_ref().map(|d| d.len()), Some(MAX_VEHICLE_TEXT));
        assert_eq!((said.actions.len(), said.actions[0].status.as_str(), said.actions[0].id.len()), (MAX_VEHICLE_ITEMS, "RUNNING", MAX_VEHICLE_WORD));
        said.check().expect("within telemetry's bounds");
    }

    /// A vertex the map names alone is the node of that name; the others go by index.
    #[test]
    fn a_named_vertex_is_the_node_of_its_name() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        let named = |v: u32, x: f64, name: &str| RouteVertex { name: Some(name.into()), ..RouteVertex::at(v, x, 0.0) };
        d.navigate_lane(&named(1, 1.0, "dock-1"), &[v(2, 2.0)], &[named(3, 3.0, "N3")], None);
        assert_eq!(nodes(d.take()), [n("v0", 0, true), n("dock-1", 2, true), n("v2", 4, true), n("N3", 6, false)]);
        d.on_state(&state("gw-1", "dock-1", 2, true, 1.0));
        assert!(d.passed(&named(1, 1.0, "dock-1")) && !d.passed(&v(1, 1.0)));
    }

    #[test]
    fn a_way_off_the_base_released_is_a_cancel_then_a_new_order() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
        d.take();
        d.navigate_lane(&v(5, 0.0), &[], &[], None);
        let out = d.take();
        assert!(matches!(out.as_slice(), [VdaOut::Instant(a)] if a[0].action_type == "cancelOrder"), "{out:?}");
    }

    /// A state of `order` with action `id` ended as `status`.
    fn ended(order: &str, last: &str, seq: u64, x: f64, id: &str, status: &str) -> State {
        let mut s = state(order, last, seq, false, x);
        s.action_states.push(mrmm_vda5050::msg::ActionState { action_id: id.into(), action_status: status.into(), ..Default::default() });
        s
    }

    /// [`ended`] FINISHED, the vehicle saying it is paused.
    fn paused(order: &str, last: &str, seq: u64, x: f64, id: &str) -> State {
        State { paused: Some(true), ..ended(order, last, seq, x, id, "FINISHED") }
    }

    #[test]
    fn a_hold_pauses_the_vehicle_and_the_next_goal_resumes_it_on_its_order_or_cancels_it_first() {
        let pause_of = |out: &[VdaOut]| out.iter().any(|o| matches!(o, VdaOut::Instant(a) if a[0].action_type == "startPause"));
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.hold();
        assert!(d.take().is_empty(), "a vehicle with nothing released ahead is left as it stands");
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0)], None);
        d.take();
        // A hold and a goal in the same tick (a new plan's first): no pause.
        d.hold();
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[v(3, 3.0)], None);
        assert!(d.take().is_empty(), "the same way again: nothing to send");
        d.hold();
        let out = d.take();
        assert!(pause_of(&out) && d.paused() && d.goal().is_none(), "{out:?}");
        d.hold();
        assert!(d.take().is_empty(), "paused once");
        // Resumed on the way released: nothing until the vehicle said it paused; then stopPause,
        // and the order goes on (an update).
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0), v(3, 3.0)], &[], None);
        assert!(d.take().is_empty(), "no stopPause before the vehicle paused (it would refuse it)");
        d.on_state(&paused("gw-1", "v0", 0, 0.2, "gw-a1"));
        let out = d.take();
        assert!(matches!(&out[0], VdaOut::Instant(a) if a[0].action_type == "stopPause"), "{out:?}");
        assert_eq!(orders(out[1..].to_vec()), [("gw-1".to_string(), 1, vec!["v2".to_string(), "v3".to_string()])]);
        d.hold();
        assert!(d.take().is_empty(), "no startPause before the vehicle said it drives again");
        d.on_state(&ended("gw-1", "v0", 0, 0.3, "gw-a2", "FINISHED"));
        assert!(pause_of(&d.take()), "now the hold pauses it");
        // Paused, then sent elsewhere: cancel, then (still paused) stopPause and a new order once
        // the cancel ended.
        d.on_state(&paused("gw-1", "v0", 0, 0.4, "gw-a3"));
        d.navigate(3.0, 5.0, None);
        let out = d.take();
        assert!(matches!(out.as_slice(), [VdaOut::Instant(a)] if a.len() == 1 && a[0].action_type == "cancelOrder"), "{out:?}");
        d.on_state(&state("gw-1", "v1", 2, false, 1.4));
        assert!(d.take().is_empty(), "no new order while the vehicle still cancels the old one");
        d.on_state(&paused("gw-1", "v1", 2, 1.4, "gw-a4"));
        let out = d.take();
        assert!(matches!(&out[0], VdaOut::Instant(a) if a[0].action_type == "stopPause"), "{out:?}");
        let o = orders(out[1..].to_vec());
        assert_eq!((o[0].0.as_str(), o[0].2[0].as_str()), ("gw-2", "v1"), "a new order from the vehicle's last node: {o:?}");
    }

    #[test]
    fn a_pause_the_vehicle_refused_needs_no_stop_pause() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
        d.take();
        d.hold();
        d.take();
        d.navigate_lane(&v(1, 1.0), &[v(2, 2.0)], &[], None);
        d.on_state(&ended("gw-1", "v0", 0, 0.2, "gw-a1", "FAILED"));
        let out = d.take();
        assert!(!d.paused() && out.iter().all(|o| !matches!(o, VdaOut::Instant(_))), "{out:?}");
    }

    #[test]
    fn a_vehicle_that_drops_the_order_is_given_the_goal_again_and_its_refusal_is_reported() {
        let mut d = drive();
        d.on_state(&state("", "v0", 0, false, 0.0));
        d.navigate_lane(&v(1, 1.0), &[], &[], None);
        d.take();
        d.on_state(&state("gw-0", "v0", 0, false, 0.0));
        assert!(d.take().is_empty(), "a late state of an earlier order of ours changes nothing");
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
