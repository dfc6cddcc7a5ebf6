//! mrmm's ROS 2 side: a robot body that is a ROS 2 robot, reached natively over rmw_zenoh (no ROS
//! installation, no bridge). [`msgs`] and [`cdr`] are the messages on the wire, [`graph`] the key
//! expressions and graph tokens, [`attachment`] what rmw_zenoh attaches to each message,
//! [`config`] the robot config's `body` section, [`link`] the session to the robot's ROS router.
//! [`nav2`] is Nav2's `NavigateToPose` action.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod action;
pub mod attachment;
pub mod cdr;
pub mod config;
pub mod error;
pub mod graph;
pub mod link;
pub mod msgs;
pub mod nav2;

pub use config::{DriveMode, Ros2Body};
pub use error::Ros2Error;
pub use link::{Input, Pose2, RosLink};
