//! A ROS 2 body's inputs as the robot machine's events: odometry, the localised pose, Nav2's
//! server and goals; what does not fit the graph, or does not decode, is counted and logged.

use mrmm_proto::{self as proto, Velocity};
use mrmm_ros2::nav2::GoalEvent;
use mrmm_ros2::{Input as RosInput, RosLink};

use mrmm_core::robot::Event;

/// Inputs of a ROS 2 body that could not be taken, counted (logged at powers of two).
pub(super) struct RosCounts {
    id: String,
    malformed: u64,
    mismatched: u64,
}

impl RosCounts {
    pub(super) fn new(id: &str) -> RosCounts {
        RosCounts { id: id.to_string(), malformed: 0, mismatched: 0 }
    }

    /// A ROS 2 body's input as the machine's event; mismatched graphs and malformed messages are
    /// counted and logged (rate-limited) instead.
    pub(super) fn event(&mut self, input: RosInput) -> Option<Event> {
        match input {
            RosInput::Odometry { pose, v, omega } => Some(Event::Odometry { pose: ros_pose(pose), velocity: Velocity { v, omega } }),
            RosInput::Pose(pose) => Some(Event::LocalisedPose(ros_pose(pose))),
            RosInput::Battery { charge, charging } => Some(Event::Battery(proto::BatteryState { charge, charging, reach_m: None })),
            RosInput::Nav2Server(up) => {
                if !up {
                    tracing::warn!(robot = %self.id, "ROS 2 graph: Nav2's action server left");
                }
                Some(Event::Nav2Server(up))
            }
            RosInput::Goal { id: goal, event } => {
                if matches!(event, GoalEvent::Feedback { .. }) {
                    tracing::debug!(robot = %self.id, ?event, "Nav2 feedback");
                } else {
                    tracing::info!(robot = %self.id, ?event, "Nav2 goal");
                }
                Some(Event::Nav2Goal { id: goal, event })
            }
            RosInput::Mismatch(why) => {
                self.mismatched += 1;
                if self.mismatched.is_power_of_two() {
                    tracing::warn!(robot = %self.id, count = self.mismatched, "ROS 2 graph: {why}");
                }
                None
            }
            RosInput::Malformed { topic, error } => {
                self.malformed += 1;
                if self.malformed.is_power_of_two() {
                    tracing::warn!(robot = %self.id, %topic, count = self.malformed, "dropped a malformed ROS 2 message: {error}");
                }
                None
            }
        }
    }
}

/// The next input of a ROS 2 body; pending without one.
pub(super) async fn recv_ros(ros: &Option<RosLink>) -> RosInput {
    match ros {
        Some(r) => r.recv().await,
        None => std::future::pending().await,
    }
}

fn ros_pose(p: mrmm_ros2::Pose2) -> proto::Pose {
    proto::Pose { x: p.x, y: p.y, theta: p.theta }
}
