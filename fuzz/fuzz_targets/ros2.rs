//! A ROS 2 body's robot under whatever its ROS graph sends: odometry and localiser poses decoded
//! from CDR as the link does, plans from central, and time.
#![no_main]

use libfuzzer_sys::fuzz_target;
use mrmm_fuzz::{frames, ros_robot, sender};
use mrmm_peer::robot::Event;
use mrmm_proto::{self as proto, Pose, RobotCommand, Velocity};
use mrmm_ros2::{cdr, link, msgs, Input};

fuzz_target!(|data: &[u8]| {
    let mut r = ros_robot("r1");
    let mut now = 0.0;
    for (sel, payload) in frames(data) {
        let ev = match sel % 6 {
            0 | 1 => match link::decode_odometry(payload) {
                Ok(Input::Odometry { pose, v, omega }) => Event::Odometry { pose: Pose { x: pose.x, y: pose.y, theta: pose.theta }, velocity: Velocity { v, omega } },
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
});
