//! What a navigation stack tells a robot about its goals (Nav2's `NavigateToPose` semantics),
//! as the robot's machine hears it: the ROS 2 link decodes the action's messages into these.

/// A goal's id (`unique_identifier_msgs/msg/UUID`).
pub type GoalId = [u8; 16];

/// What became of a goal, as the link learns it.
#[derive(Debug, Clone, PartialEq)]
pub enum GoalEvent {
    /// The server accepted the goal.
    Accepted,
    /// The server rejected it.
    Rejected,
    /// The goal ended with this status ([`status`]).
    Finished(i8),
    /// No answer or an unreadable one: the goal's fate is unknown.
    Failed(String),
    /// The navigator's feedback: recovery behaviours run so far, metres left.
    Feedback { recoveries: u16, distance_remaining: f32 },
}

/// `action_msgs/msg/GoalStatus` values.
pub mod status {
    pub const UNKNOWN: i8 = 0;
    pub const ACCEPTED: i8 = 1;
    pub const EXECUTING: i8 = 2;
    pub const CANCELING: i8 = 3;
    pub const SUCCEEDED: i8 = 4;
    pub const CANCELED: i8 = 5;
    pub const ABORTED: i8 = 6;

    /// A status's name, for logs and telemetry.
    pub fn name(s: i8) -> &'static str {
        match s {
            ACCEPTED => "accepted",
            EXECUTING => "executing",
            CANCELING => "canceling",
            SUCCEEDED => "succeeded",
            CANCELED => "canceled",
            ABORTED => "aborted",
            _ => "unknown",
        }
    }
}

/// How mrmm moves a ROS 2 robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveMode {
    /// mrmm's own controller publishes `geometry_msgs/Twist` on `cmd_vel_topic`, closing the loop
    /// on odometry (or the localiser's pose) within the robot's kinematic limits.
    CmdVel,
    /// Goals go to Nav2's `NavigateToPose` action.
    Nav2,
}
