//! The `body: { kind: "ros2", … }` section of a robot config: where the robot's ROS 2 graph is
//! and how to drive it, validated into one-line errors.

use serde::Deserialize;

use crate::error::Ros2Error;
use crate::graph::validate_name;

pub use mrmm_proto::nav::DriveMode;

/// A robot body that is a ROS 2 robot speaking rmw_zenoh.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2Body {
    /// The robot's own Zenoh router (rmw_zenoh's `rmw_zenohd`), `tcp/<address>:<port>`.
    #[serde(default = "default_router")]
    pub router: String,
    /// ROS_DOMAIN_ID of the robot's graph.
    #[serde(default)]
    pub domain_id: u32,
    /// The namespace of the robot's topics and of mrmm's node (relative topic names are
    /// resolved in it).
    #[serde(default = "default_namespace")]
    pub namespace: String,
    /// The name of mrmm's node in the ROS graph (default `mrmm_<robot id>`).
    #[serde(default)]
    pub node_name: Option<String>,
    #[serde(default = "default_drive")]
    pub drive: DriveMode,
    #[serde(default = "default_odom")]
    pub odom_topic: String,
    /// A localiser's pose (`geometry_msgs/PoseWithCovarianceStamped`, e.g. `/amcl_pose`) used as
    /// the robot's position instead of odometry's; `null` to use odometry alone.
    #[serde(default)]
    pub pose_topic: Option<String>,
    #[serde(default = "default_cmd_vel")]
    pub cmd_vel_topic: String,
    /// The robot's battery (`sensor_msgs/BatteryState`); `null` for a robot without one.
    #[serde(default = "default_battery")]
    pub battery_topic: Option<String>,
    #[serde(default = "default_nav2_action")]
    pub nav2_action: String,
    /// The frame goals and poses are given in.
    #[serde(default = "default_frame")]
    pub frame_id: String,
    /// Odometry older than this stops the robot (zero twist) until it is fresh again.
    #[serde(default = "default_odom_timeout")]
    pub odom_timeout_ms: u64,
    /// Stop the robot while it has no link to any other node of the fleet.
    #[serde(default = "default_true")]
    pub stop_on_fleet_loss: bool,
}

fn default_router() -> String {
    "tcp/127.0.0.1:7447".into()
}
fn default_namespace() -> String {
    "/".into()
}
fn default_drive() -> DriveMode {
    DriveMode::CmdVel
}
fn default_odom() -> String {
    "/odom".into()
}
fn default_battery() -> Option<String> {
    Some("/battery_state".into())
}
fn default_cmd_vel() -> String {
    "/cmd_vel".into()
}
fn default_nav2_action() -> String {
    "/navigate_to_pose".into()
}
fn default_frame() -> String {
    "map".into()
}
fn default_odom_timeout() -> u64 {
    500
}
fn default_true() -> bool {
    true
}

impl Ros2Body {
    /// Checks every field; errors read `body.<field>: problem`.
    pub fn validate(&self) -> Result<(), Ros2Error> {
        let cfg = |m: String| Ros2Error::Config(m);
        let addr = self
            .router
            .strip_prefix("tcp/")
            .ok_or_else(|| cfg(format!("body.router: {:?}: the robot's ROS router is a tcp/<address>:<port> endpoint", self.router)))?;
        mrmm_net::net::validate_endpoint(&self.router).map_err(|e| cfg(format!("body.router: {e}")))?;
        if addr.contains('#') {
            return Err(cfg(format!("body.router: {:?}: no endpoint options", self.router)));
        }
        if self.domain_id > 232 {
            return Err(cfg(format!("body.domain_id: must be 0..=232 (got {})", self.domain_id)));
        }
        validate_name("body.namespace", &self.namespace)?;
        if !self.namespace.starts_with('/') {
            return Err(cfg(format!("body.namespace: {:?} must start with /", self.namespace)));
        }
        if let Some(n) = &self.node_name {
            validate_name("body.node_name", n)?;
            if n.contains('/') {
                return Err(cfg(format!("body.node_name: {n:?} is a name, not a path")));
            }
        }
        validate_name("body.odom_topic", &self.odom_topic)?;
        validate_name("body.cmd_vel_topic", &self.cmd_vel_topic)?;
        validate_name("body.nav2_action", &self.nav2_action)?;
        if let Some(p) = &self.pose_topic {
            validate_name("body.pose_topic", p)?;
        }
        if let Some(b) = &self.battery_topic {
            validate_name("body.battery_topic", b)?;
        }
        if self.frame_id.is_empty() || self.frame_id.len() > 100 || !self.frame_id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/') {
            return Err(cfg(format!("body.frame_id: {:?} must be 1 to 100 characters of A-Z a-z 0-9 _ /", self.frame_id)));
        }
        if !(50..=10_000).contains(&self.odom_timeout_ms) {
            return Err(cfg(format!("body.odom_timeout_ms: must be 50..=10000 (got {})", self.odom_timeout_ms)));
        }
        Ok(())
    }

    /// The node name in the ROS graph.
    pub fn node_name_for(&self, robot_id: &str) -> String {
        self.node_name.clone().unwrap_or_else(|| format!("mrmm_{}", robot_id.replace('-', "_")))
    }
}
