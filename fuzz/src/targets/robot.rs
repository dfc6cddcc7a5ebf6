//! A robot's machine under commands (plans, orders, admissions, leaves) from anyone, teammates'
//! barrier arrivals, liveliness changes and time, decoded as the robot's runtime does.

use crate::{frames, robot, sender};
use mrmm_core::robot::Event;
use mrmm_proto::{self as proto, RobotCommand, SyncArrival, Time};

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let mut r = robot("r1");
    let mut now = Time::ZERO;
    for (sel, payload) in frames(data) {
        let ev = match sel % 8 {
            0..=2 => match proto::from_json::<RobotCommand>("robot command", payload) {
                Ok(cmd) => Event::Command { cmd, from: sender(sel / 8) },
                Err(_) => continue,
            },
            3 => match proto::from_json::<SyncArrival>("sync arrival", payload) {
                Ok(a) => Event::Heard(a),
                Err(_) => continue,
            },
            4 => Event::MemberAlive(String::from_utf8_lossy(payload).into_owned().into()),
            5 => Event::MemberGone(String::from_utf8_lossy(payload).into_owned().into()),
            6 => Event::CentralAlive(sel / 8 % 2 == 0),
            _ => {
                now += f64::from(sel / 8) * 0.2 + 0.05;
                Event::Tick
            }
        };
        let _ = r.handle(now, ev);
        let _ = r.handle(now, Event::TelemetryDue);
    }
}
