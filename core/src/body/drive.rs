//! The robot's body, whichever it is: the simulated unicycle ([`Body`]), a ROS 2 robot
//! ([`RosDrive`]) or a VDA 5050 vehicle ([`VdaDrive`]). The robot's state machine talks to this,
//! not to any one body.

use mrmm_proto::{Pose, Time, Velocity};

use crate::body::ros::{RosDrive, Step};
use crate::body::vda::VdaDrive;
use crate::body::{Body, Onward};
use mrmm_proto::traffic::RouteVertex;

#[derive(Debug, Clone)]
pub enum Drive {
    Sim(Box<Body>),
    Ros(Box<RosDrive>),
    Vda(Box<VdaDrive>),
}

impl Drive {
    pub fn pose(&self) -> Pose {
        match self {
            Drive::Sim(b) => b.pose(),
            Drive::Ros(r) => r.pose(),
            Drive::Vda(d) => d.pose(),
        }
    }

    pub fn velocity(&self) -> Velocity {
        match self {
            Drive::Sim(b) => b.velocity(),
            Drive::Ros(r) => r.velocity(),
            Drive::Vda(d) => d.velocity(),
        }
    }

    pub fn goal(&self) -> Option<(f64, f64)> {
        match self {
            Drive::Sim(b) => b.goal(),
            Drive::Ros(r) => r.goal(),
            Drive::Vda(d) => d.goal(),
        }
    }

    /// Neither driving to a goal nor turning on the spot (a ROS 2 body does not turn at
    /// barriers: idle once it has no goal).
    pub fn idle(&self) -> bool {
        match self {
            Drive::Sim(b) => b.idle(),
            Drive::Ros(r) => r.goal().is_none(),
            Drive::Vda(d) => d.goal().is_none(),
        }
    }

    pub fn navigate_capped(&mut self, x: f64, y: f64, speed: Option<f64>) {
        self.navigate_through(x, y, None, speed);
    }

    /// Drives to (x, y), no faster than `speed`; `then`, the point the plan drives on to from
    /// there: the simulated body rounds the corner on an arc; a ROS 2 body stops at each goal
    /// (its own controller, or Nav2, drives the goals it is sent).
    pub fn navigate_through(&mut self, x: f64, y: f64, then: Option<Onward>, speed: Option<f64>) {
        match self {
            Drive::Sim(b) => b.navigate_through(x, y, then, speed),
            Drive::Ros(r) => r.navigate_capped(x, y, speed),
            Drive::Vda(d) => d.navigate(x, y, speed),
        }
    }

    /// Drives to the lanes' vertex `v` (traffic granted the lane to it).
    pub fn navigate_vertex(&mut self, v: &RouteVertex, speed: Option<f64>) {
        self.navigate_lane(v, &[], &[], speed);
    }

    /// Drives to the lanes' vertex `v`, with `granted` the vertices traffic granted after it and
    /// `then` the rest of the route: a VDA 5050 vehicle is released all it was granted (it drives
    /// on through them) and told the rest as its order's horizon; any other body drives to `v`.
    pub fn navigate_lane(&mut self, v: &RouteVertex, granted: &[RouteVertex], then: &[RouteVertex], speed: Option<f64>) {
        match self {
            Drive::Vda(d) => d.navigate_lane(v, granted, then, speed),
            _ => self.navigate_through(v.x, v.y, None, speed),
        }
    }

    /// Whether the body said it passed the lanes' vertex `v` last (a VDA 5050 vehicle, which
    /// drives on through it; any other body stops at a vertex, and is there or not).
    pub fn passed(&self, v: &RouteVertex) -> bool {
        match self {
            Drive::Vda(d) => d.passed(v),
            _ => false,
        }
    }

    /// Whether the body drives on through the vertices it was granted (a VDA 5050 vehicle), so
    /// that it says when it passed a vertex instead of stopping at it.
    pub fn drives_on(&self) -> bool {
        matches!(self, Drive::Vda(_))
    }

    /// The battery's state, if the body has one it knows of: the simulated body's model at its
    /// top speed; a ROS 2 robot's last `sensor_msgs/BatteryState`.
    pub fn battery(&self) -> Option<mrmm_proto::BatteryState> {
        match self {
            Drive::Sim(b) => b.battery().map(|bat| bat.state(b.limits().max_speed)),
            Drive::Ros(r) => r.battery(),
            Drive::Vda(d) => d.battery(),
        }
    }

    /// Why the body cannot get to its goal: the simulated one's battery is empty; a ROS 2 body's
    /// Nav2 rejected or aborted it, or has no server.
    pub fn stuck(&self) -> Option<&str> {
        match self {
            Drive::Sim(b) if b.goal().is_some() && b.battery().is_some_and(|b| b.empty()) => Some("its battery is empty"),
            Drive::Sim(_) => None,
            Drive::Ros(r) => r.stuck(),
            Drive::Vda(d) => d.stuck(),
        }
    }

    /// A VDA 5050 vehicle's own word on itself (telemetry's `vehicle`); other bodies have none.
    pub fn vehicle(&self) -> Option<&mrmm_proto::VehicleState> {
        match self {
            Drive::Vda(d) => d.said(),
            _ => None,
        }
    }

    pub fn hold(&mut self) {
        match self {
            Drive::Sim(b) => b.hold(),
            Drive::Ros(r) => r.hold(),
            Drive::Vda(d) => d.hold(),
        }
    }

    /// Faces (x, y), turning on the spot, when the plan waits at a barrier: the simulated body
    /// does; a ROS 2 body, already stopped there, keeps its heading (its own controller, or
    /// Nav2, turns when the next goal comes).
    pub fn face(&mut self, x: f64, y: f64) {
        match self {
            Drive::Sim(b) => b.face(x, y),
            Drive::Ros(_) | Drive::Vda(_) => {}
        }
    }

    /// Advances the body: the simulated one by `dt` simulated seconds, the ROS one's controller
    /// at wall time `now` (its twist, if any, is returned); a VDA 5050 vehicle moves by itself.
    pub fn step(&mut self, now: Time, dt: f64) -> Step {
        match self {
            Drive::Sim(b) => Step { arrived: b.step(dt), ..Step::default() },
            Drive::Ros(r) => r.step(now),
            Drive::Vda(_) => Step::default(),
        }
    }
}
