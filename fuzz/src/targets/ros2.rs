//! A ROS 2 body's robot under whatever its ROS graph sends: odometry and localiser poses decoded
//! from CDR as the link does, plans from central, and time; with a Nav2 drive (chosen by the first
//! byte), also the action server coming and going and answers about goals decoded as the link
//! decodes them.

use crate::{frames, ros_robot_driven, sender};
use mrmm_core::robot::Event;
use mrmm_proto::{self as proto, Pose, RobotCommand, Time, Velocity};
use mrmm_ros2::nav2::{self, GoalEvent};
use mrmm_ros2::{cdr, link, msgs, Input};

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let mut r = ros_robot_driven("r1", if data.first().is_some_and(|b| b % 2 == 1) { "nav2" } else { "cmd_vel" });
    let mut now = Time::ZERO;
    for (sel, payload) in frames(data) {
        let ev = match sel % 8 {
            6 => Event::Nav2Server(sel / 8 % 2 == 0),
            7 => {
                // Goal ids: the robot's own are random, so answers are about strangers' goals;
                // what matters is that no answer hurts.
                let mut id = [0u8; 16];
                for (d, s) in id.iter_mut().zip(payload) {
                    *d = *s;
                }
                let event = match sel / 8 % 5 {
                    0 => nav2::decode_accepted(payload).map(|a| if a { GoalEvent::Accepted } else { GoalEvent::Rejected }),
                    1 => nav2::decode_status(payload).map(GoalEvent::Finished),
                    2 => nav2::decode_cancel(payload).map(GoalEvent::Finished),
                    3 => nav2::decode_feedback(payload).map(|(_, e)| e),
                    _ => Ok(GoalEvent::Failed(String::from_utf8_lossy(payload).into_owned())),
                };
                match event {
                    Ok(event) => Event::Nav2Goal { id, event },
                    Err(_) => continue,
                }
            }
            0 | 1 => match link::decode_odometry(payload) {
                Ok(Input::Odometry { pose, v, omega }) => {
                    Event::Odometry { pose: Pose { x: pose.x, y: pose.y, theta: pose.theta }, velocity: Velocity { v, omega } }
                }
                _ => continue,
            },
            2 => match cdr::decode::<msgs::PoseWithCovarianceStamped>(payload) {
                Ok(p) => Event::LocalisedPose(Pose { x: p.pose.pose.position.x, y: p.pose.pose.position.y, theta: p.pose.pose.orientation.yaw() }),
                Err(_) => continue,
            },
            3 => match proto::from_json::<RobotCommand>("robot command", payload) {
                Ok(cmd) => Event::Command { cmd, from: sender(sel / 6) },
                Err(_) => continue,
            },
            4 => Event::FleetLink(sel / 6 % 2 == 0),
            _ => {
                now += f64::from(sel / 6) * 0.02 + 0.02;
                Event::Tick
            }
        };
        let _ = r.handle(now, ev);
        let _ = cdr::decode::<msgs::Twist>(payload);
    }
}
