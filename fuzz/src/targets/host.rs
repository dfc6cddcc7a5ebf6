//! A mission host leading patrol `p` (central's) and a robot node's host following it, under chain
//! messages, starts, controls, telemetry, status reports and planner answers from anyone.

use crate::{frames, hosts, sender};
use mrmm_core::mission::host::Event;
use mrmm_proto::{self as proto, ChainEnvelope, MissionCtl, MissionPlan, MissionStart, MissionView};

/// One input, as libFuzzer hands it over.
pub fn run(data: &[u8]) {
    let (mut head, mut follower) = hosts();
    for (sel, payload) in frames(data) {
        let from = sender(sel / 16);
        for h in [&mut head, &mut follower] {
            match sel % 16 {
                0..=3 => {
                    if let Ok(envelope) = proto::from_json::<ChainEnvelope>("chain message", payload) {
                        h.feed(Event::Chain { envelope: Box::new(envelope), from: from.clone() });
                    }
                }
                4 => {
                    if let Ok(start) = proto::from_json::<MissionStart>("mission start", payload) {
                        let query = h.query();
                        h.feed(Event::Start { query, start: Box::new(start), from: from.clone() });
                    }
                }
                5 | 6 => {
                    if let Ok(ctl) = proto::from_json::<MissionCtl>("mission control", payload) {
                        let query = h.query();
                        h.feed(Event::Ctl { query, mission: "p".into(), ctl, from: from.clone() });
                    }
                }
                7 => {
                    if let Ok(t) = proto::decode_telemetry(payload) {
                        h.feed(Event::Telemetry(Box::new(t)));
                    }
                }
                8 => {
                    if let Ok(view) = proto::from_json::<MissionView>("mission status", payload) {
                        h.feed(Event::MissionStatus { view: Box::new(view), from: from.clone() });
                    }
                }
                9 => {
                    // A planner service's answer to the last plan request (what the driver
                    // decodes once the answer's sender proved to be a planner).
                    if let (Ok(plan), Some((mission, epoch))) = (proto::from_json::<MissionPlan>("plan", payload), h.last_plan.clone()) {
                        h.feed(Event::Planned { mission: mission.into(), epoch, result: Ok(Box::new(plan)) });
                    }
                }
                10 => h.feed(Event::HostGone(from.id.clone().into())),
                11 => h.feed(Event::HostAlive(from.id.clone().into())),
                12 => h.feed(Event::RobotGone(from.id.clone().into())),
                13 => {
                    let query = h.query();
                    h.feed(Event::View { query, mission: String::from_utf8_lossy(payload).into_owned().into() });
                }
                14 => h.feed(Event::StatusTick),
                _ => {
                    h.now += f64::from(sel / 16) * 0.3 + 0.02;
                    h.feed(Event::Tick);
                }
            }
        }
    }
}
