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
mod tests;
