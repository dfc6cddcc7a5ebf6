//! What a robot's machine is made of: its identity, kinematics, start and body, as the driver
//! read them from the robot's config file (`mrmm_peer::config::RobotConfig::setup`) or a
//! simulation chose them.

use mrmm_proto::Pose;

use crate::body::Limits;

/// A robot as its machine knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotSetup {
    pub id: mrmm_proto::RobotId,
    pub robot_type: String,
    /// What the robot can do at start (changed at runtime by capabilities commands).
    pub capabilities: Vec<String>,
    pub limits: Limits,
    pub start: Pose,
    /// Simulated seconds per wall-clock second.
    pub time_scale: f64,
    /// Whether the robot keeps state across restarts (a state dir): its capabilities changes
    /// are then kept ([`crate::robot::Command::KeepCapabilities`]).
    pub durable: bool,
    pub body: BodyKind,
    /// A simulated body's battery, as it starts (None: it never runs out).
    pub battery: Option<crate::body::battery::Battery>,
}

/// The body the machine drives.
#[derive(Debug, Clone, PartialEq)]
pub enum BodyKind {
    /// The simulated unicycle.
    Sim,
    /// A ROS 2 robot.
    Ros {
        /// Seconds without odometry after which the body halts.
        odom_timeout_s: f64,
        /// Whether the body halts when the robot has no link to the fleet left.
        stop_on_fleet_loss: bool,
        /// Whether a localiser's pose (rather than odometry) says where the robot is.
        localised: bool,
        /// Goals go to Nav2's `NavigateToPose` action (else mrmm's own `cmd_vel` controller).
        nav2: Option<Nav2Setup>,
    },
    /// A VDA 5050 vehicle, driven by orders through the gateway.
    Vda {
        /// Order ids begin with this (unique per gateway start: a vehicle keeps the ids it had).
        order_prefix: String,
        /// The `mapId` of the nodes of its orders.
        map_id: String,
    },
}

/// A Nav2 body's action and the seed of its goal ids (they must not repeat across restarts: the
/// server keeps finished goals).
#[derive(Debug, Clone, PartialEq)]
pub struct Nav2Setup {
    pub action: String,
    pub goal_seed: mrmm_proto::nav::GoalId,
}

impl RobotSetup {
    /// A simulated robot of `robot_type` at `start` (`time_scale` 1, no capabilities, not durable).
    pub fn sim(id: &str, robot_type: &str, limits: Limits, start: Pose) -> RobotSetup {
        RobotSetup {
            id: id.into(),
            robot_type: robot_type.to_string(),
            capabilities: Vec::new(),
            limits,
            start,
            time_scale: 1.0,
            durable: false,
            body: BodyKind::Sim,
            battery: None,
        }
    }
}
