//! Central's system manager under operator requests on every operator key, robots' telemetry and
//! missions' status reports, all decoded from the wire as central's driver does.

use crate::{central, frames, sender};
use mrmm_core::central::system::{Event, Request};
use mrmm_proto::{self as proto, Key, MissionView, SystemCmd};

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let mut c = central();
    for (sel, payload) in frames(data) {
        let text = String::from_utf8_lossy(payload);
        let key = match sel % 16 {
            0 => Some(Key::SystemStatus.to_string()),
            1 => Some(Key::SystemRobots.to_string()),
            2 => Some(Key::SystemRobot(text.to_string().into()).to_string()),
            3 => Some(Key::SystemMissions.to_string()),
            4 => Some(Key::SystemMission(text.to_string().into()).to_string()),
            5 => Some(Key::SystemCmd(SystemCmd::Goto).to_string()),
            6 => Some(Key::SystemCmd(SystemCmd::Move).to_string()),
            7 => Some(Key::SystemCmd(SystemCmd::Create).to_string()),
            8 => Some(Key::SystemCmd(SystemCmd::Terminate).to_string()),
            _ => None,
        };
        if let Some(key) = key {
            if let Ok(request) = Request::decode(&key, payload) {
                c.operator(request);
            }
            continue;
        }
        match sel % 16 {
            9 => {
                // Telemetry: the driver takes it only from the robot it names.
                if let Ok(t) = proto::decode_telemetry(payload) {
                    c.feed(Event::Telemetry(Box::new(t)));
                }
            }
            10 => {
                if let Ok(view) = proto::from_json::<MissionView>("mission status", payload) {
                    c.feed(Event::MissionStatus { view: Box::new(view), from: sender(sel / 16) });
                }
            }
            11 => c.feed(Event::RobotGone { id: text.to_string().into() }),
            12 => c.feed(Event::RobotAlive { id: text.to_string().into() }),
            13 => c.feed(Event::HostGone { node: text.to_string().into() }),
            _ => {
                c.now += f64::from(sel / 16) * 0.5 + 0.05;
                c.feed(Event::Tick);
            }
        }
    }
    let _ = c.sm.status(c.now);
}
