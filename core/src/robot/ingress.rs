//! What a robot hears, translated at its edge: a message's key, payload and proven sender become
//! an [`Event`] of the robot's machine, or a [`Refused`] saying why not. The same translation runs
//! in the robot's driver (`mrmm_peer::runtime`) and in the seeded simulations, with the one
//! publication policy of the protocol (`mrmm_proto::policy`): a forged or malformed message is
//! refused here, wherever it arrives.

use mrmm_proto::policy::{may_publish, Publication};
use mrmm_proto::{self as proto, Key, RobotCommand, Sender, SyncArrival, SyncRelease};

use crate::edge::json;

use super::{Event, Robot};
pub use crate::edge::{Incoming, Refused};

/// What a sealed message on `key` is (for the driver to prove its sender under that name).
pub fn sealed(key: &str) -> &'static str {
    match Key::parse(key) {
        Some(Key::TeamSync { .. } | Key::TeamArrive { .. }) => "barrier arrival",
        Some(Key::TeamRelease { .. }) => "barrier release",
        Some(Key::RobotCmd(_)) => "robot command",
        Some(Key::TrafficOrder { .. }) => "traffic order",
        _ => "message",
    }
}

impl Robot {
    /// Translates what the robot heard into an event of its machine: commands on its own command
    /// key, its teams' barrier arrivals and releases (from whom the policy allows), its teams'
    /// member tokens and central's token.
    pub fn ingress(&self, m: Incoming<'_>) -> Result<Event, Refused> {
        let proven = |what: &'static str| m.from.cloned().ok_or(Refused::Unproven { what });
        let entitled = |p: Publication<'_>, from: &Sender| may_publish(p, from).map_err(|what| Refused::NotEntitled { from: from.clone(), what });
        match Key::parse(m.key) {
            Some(Key::RobotCmd(id)) if id == self.id() => {
                let from = proven("robot command")?;
                let cmd: RobotCommand = json("robot command", m.payload)?;
                Ok(Event::Command { cmd, from })
            }
            Some(Key::TeamSync { team, .. } | Key::TeamArrive { team, .. }) => {
                let from = proven("barrier arrival")?;
                let a: SyncArrival = json("barrier arrival", m.payload)?;
                entitled(Publication::Arrival(a.robot.as_str()), &from)?;
                Ok(if self.own_team() == Some(team.as_str()) { Event::Heard(a) } else { Event::HeardIn(team, a) })
            }
            Some(Key::TeamRelease { .. }) => {
                let from = proven("barrier release")?;
                let r: SyncRelease = json("barrier release", m.payload)?;
                entitled(Publication::Release(r.leader.as_str()), &from)?;
                Ok(Event::Released(r))
            }
            Some(Key::TrafficOrder { map, robot }) if robot == self.id() => {
                let from = proven("traffic order")?;
                // A robot's orders count only while central is away, from a deputy the map's
                // authority named in the orders this robot drives by.
                let deputy = from.role == proto::Role::Robot
                    && !self.central_up
                    && self.traffic.as_ref().is_some_and(|g| g.map().hash == map && g.deputies().iter().any(|d| d.as_str() == from.id));
                entitled(Publication::TrafficOrder { deputy }, &from)?;
                let order = proto::from_json_max("traffic order", m.payload, proto::traffic::MAX_MESSAGE)
                    .map_err(|e| Refused::Malformed { what: "traffic order", why: e.to_string() })?;
                Ok(Event::Traffic { map, order, deputy })
            }
            Some(Key::TeamMember { robot, .. }) => Ok(if m.put { Event::MemberAlive(robot) } else { Event::MemberGone(robot) }),
            Some(Key::HostAlive(host)) if host == proto::CENTRAL_HOST => Ok(Event::CentralAlive(m.put)),
            _ => Err(Refused::Unexpected { key: m.key.chars().take(200).collect() }),
        }
    }

    /// The team of the plan being executed (whose barriers are this robot's own).
    fn own_team(&self) -> Option<&str> {
        self.exec.as_ref().map(|e| e.assignment.team.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Limits;
    use crate::robot::RobotSetup;
    use mrmm_proto::{Pose, Role};

    fn robot() -> Robot {
        Robot::new(RobotSetup::sim("r1", "ground", Limits { max_speed: 1.0, max_turn_rate: 1.0 }, Pose::default()))
    }

    fn arrival(robot: &str) -> Vec<u8> {
        serde_json::to_vec(&SyncArrival { robot: robot.into(), epoch: 1, point: 0, round: 0 }).expect("json")
    }

    #[test]
    fn a_robot_hears_only_what_its_sender_may_say() {
        let r = robot();
        let r2 = Sender::new(Role::Robot, "r2");
        let key = Key::TeamSync { team: "p".into(), point: 0, round: 0 }.to_string();
        let heard = |payload: &[u8], from: Option<&Sender>| r.ingress(Incoming { key: &key, payload, put: true, from });
        // No plan yet: p is not its own team, so the arrival is a wider team's.
        assert!(matches!(heard(&arrival("r2"), Some(&r2)), Ok(Event::HeardIn(t, a)) if t == "p" && a.robot == "r2"));
        // r2 speaking for r3 is refused; so is an unsealed arrival and a malformed one.
        assert_eq!(heard(&arrival("r3"), Some(&r2)), Err(Refused::NotEntitled { from: r2.clone(), what: "publish the barrier arrival of r3".into() }));
        assert_eq!(heard(&arrival("r2"), None), Err(Refused::Unproven { what: "barrier arrival" }));
        assert!(matches!(heard(b"{\"robot\":", Some(&r2)), Err(Refused::Malformed { what: "barrier arrival", .. })));
        // A release by someone other than the leader it names.
        let release = serde_json::to_vec(&SyncRelease { leader: "r3".into(), epoch: 1, point: 0, round: 0 }).expect("json");
        let key = Key::TeamRelease { team: "p".into(), point: 0, round: 0 }.to_string();
        assert!(matches!(r.ingress(Incoming { key: &key, payload: &release, put: true, from: Some(&r2) }), Err(Refused::NotEntitled { .. })));
        // Commands on its own key only.
        let goto = br#"{"cmd":"goto","x":1,"y":2}"#;
        let central = Sender::new(Role::Central, "central");
        let own = Key::RobotCmd("r1".into()).to_string();
        assert!(matches!(r.ingress(Incoming { key: &own, payload: goto, put: true, from: Some(&central) }), Ok(Event::Command { .. })));
        let other = Key::RobotCmd("r2".into()).to_string();
        assert!(matches!(r.ingress(Incoming { key: &other, payload: goto, put: true, from: Some(&central) }), Err(Refused::Unexpected { .. })));
        // Tokens: members come and go, central's says whether it is up.
        let member = Key::TeamMember { subteam: "p/ground".into(), robot: "r2".into() }.to_string();
        assert_eq!(r.ingress(Incoming { key: &member, payload: b"", put: false, from: None }), Ok(Event::MemberGone("r2".into())));
        let central_key = Key::HostAlive(proto::CENTRAL_HOST.into()).to_string();
        assert_eq!(r.ingress(Incoming { key: &central_key, payload: b"", put: true, from: None }), Ok(Event::CentralAlive(true)));
    }
}
