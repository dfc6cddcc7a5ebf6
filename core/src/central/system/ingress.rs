//! What central's system manager hears on its subscriptions, translated at its edge: robots'
//! telemetry, missions' status, and the liveliness of robots and hosts become [`Event`]s, or a
//! [`Refused`] saying why not — with the protocol's one publication policy, in central's driver
//! (`mrmm_manager::central`) and the simulations alike. (Operator queries are the driver's to
//! hold; the machine checks their payloads.)

use mrmm_proto::Key;

use super::Event;
use crate::edge::{self, Incoming, Refused};

/// What a sealed message on `key` is (for the driver to prove its sender under that name), or
/// `None` for the liveliness tokens, which carry no seal.
pub fn sealed(key: &str) -> Option<&'static str> {
    match Key::parse(key)? {
        Key::RobotTelemetry(_) => Some("telemetry"),
        Key::MissionStatus(_) => Some("mission status"),
        _ => None,
    }
}

/// Translates a publication or a liveliness change into the system manager's event.
pub fn ingress(m: Incoming<'_>) -> Result<Event, Refused> {
    match Key::parse(m.key) {
        Some(Key::RobotAlive(id)) => Ok(if m.put { Event::RobotAlive { id } } else { Event::RobotGone { id } }),
        Some(Key::HostAlive(node)) => Ok(if m.put { Event::HostAlive { node } } else { Event::HostGone { node } }),
        Some(Key::RobotTelemetry(id)) => Ok(Event::Telemetry(Box::new(edge::telemetry(&m, id.as_str())?))),
        Some(Key::MissionStatus(name)) => {
            let (view, from) = edge::mission_status(&m, name.as_str())?;
            Ok(Event::MissionStatus { view: Box::new(view), from })
        }
        _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::{Role, Sender};

    #[test]
    fn central_hears_telemetry_only_from_the_robot_it_is_of() {
        let key = Key::RobotTelemetry("r1".into()).to_string();
        let t = mrmm_proto::encode_telemetry(&mrmm_proto::Telemetry::resting("r1", 0.0)).expect("telemetry");
        let heard = |from: Option<&Sender>| ingress(Incoming { key: &key, payload: &t, put: true, from });
        assert!(matches!(heard(Some(&Sender::new(Role::Robot, "r1"))), Ok(Event::Telemetry(_))));
        assert!(matches!(heard(Some(&Sender::new(Role::Robot, "r2"))), Err(Refused::NotEntitled { .. })));
        assert!(matches!(heard(None), Err(Refused::Unproven { .. })));
        let gone = Key::HostAlive("h1".into()).to_string();
        assert_eq!(sealed(&gone), None);
        assert_eq!(ingress(Incoming { key: &gone, payload: b"", put: false, from: None }), Ok(Event::HostGone { node: "h1".into() }));
    }
}
