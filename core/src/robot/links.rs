//! The robot's edge, outward: its team as the network sees it — which keys its arrivals and
//! releases go on and whom they are for, what it subscribes to — kept in step with its
//! [`Command`]s. The robot's driver (`mrmm_peer::runtime`) and the simulations both publish
//! through [`Links::egress`] and subscribe to [`Links::subscriptions`].

use mrmm_proto::{BarrierMode, Key, Pattern, RobotId, Role, ScopeMembers, Sender};

use super::Command;
use crate::egress::{Audience, Out, Sub};

/// The team a robot is in, on the network.
#[derive(Debug, Clone, PartialEq)]
pub struct TeamLinks {
    /// Its own (leaf) team's path: its barriers are this team's.
    pub team: String,
    /// Where its member token is (`<team>/<type>`).
    pub subteam: String,
    pub mode: BarrierMode,
    /// The other members of the plan: whom its barrier messages are for.
    pub to: Vec<Sender>,
    /// The wider teams whose barriers the plan has: each one's path and whom arrivals are for.
    pub wide: Vec<(String, Vec<Sender>)>,
    /// It leads the team's barriers (and hears arrivals) under [`BarrierMode::Leader`].
    pub leading: bool,
}

impl TeamLinks {
    /// Robot `id` in `team` with the plan's `members` and wider `scopes`.
    pub fn new(id: &str, team: &str, subteam: &str, mode: BarrierMode, members: &[RobotId], scopes: &[ScopeMembers]) -> TeamLinks {
        let others = |ms: &[RobotId]| ms.iter().filter(|m| m.as_str() != id).map(|m| Sender::new(Role::Robot, m.to_string())).collect::<Vec<_>>();
        TeamLinks {
            team: team.to_string(),
            subteam: subteam.to_string(),
            mode,
            to: others(members),
            wide: scopes.iter().map(|s| (s.team.clone(), others(&s.members))).collect(),
            leading: false,
        }
    }

    /// The widest team the plan has barriers with (wider teams contain its own: the shortest
    /// path): whose member tokens it watches.
    pub fn widest(&self) -> &str {
        self.wide.iter().map(|(t, _)| t.as_str()).chain([self.team.as_str()]).min_by_key(|t| t.len()).unwrap_or(&self.team)
    }

    /// Where its arrival at (point, round) goes: every member's barrier, or the leader's.
    pub fn arrival_key(&self, point: u32, round: u32) -> Key {
        match self.mode {
            BarrierMode::Mesh => Key::TeamSync { team: self.team.clone(), point, round },
            BarrierMode::Leader => Key::TeamArrive { team: self.team.clone(), point, round },
        }
    }

    /// What it hears: its team's barriers as its mode runs them (the leader's arrivals only
    /// while it leads), the wider teams' barriers; never its own messages.
    pub fn subscriptions(&self) -> Vec<Sub> {
        let mut subs = match self.mode {
            BarrierMode::Mesh => vec![Sub::remote(Pattern::TeamSync(self.team.clone()))],
            BarrierMode::Leader => {
                let mut s = vec![Sub::remote(Pattern::TeamRelease(self.team.clone()))];
                if self.leading {
                    s.push(Sub::remote(Pattern::TeamArrive(self.team.clone())));
                }
                s
            }
        };
        subs.extend(self.wide.iter().map(|(t, _)| Sub::remote(Pattern::TeamSync(t.clone()))));
        subs
    }
}

/// A robot's links: its telemetry's key, and its team while it has one.
#[derive(Debug, Clone, PartialEq)]
pub struct Links {
    id: RobotId,
    team: Option<TeamLinks>,
}

impl Links {
    pub fn new(id: &str) -> Links {
        Links { id: id.into(), team: None }
    }

    pub fn team(&self) -> Option<&TeamLinks> {
        self.team.as_ref()
    }

    /// Keeps up with command `c` (joining, leaving, leading a team) and says what it puts on the
    /// network, if anything: arrivals, releases and telemetry. Commands for the node itself
    /// (replies, bodies, the state dir) put nothing.
    pub fn egress(&mut self, c: &Command) -> Option<Out> {
        match c {
            Command::JoinTeam { team, subteam, barrier, members, scopes } => {
                self.team = Some(TeamLinks::new(self.id.as_str(), team, subteam, *barrier, members, scopes));
                None
            }
            Command::LeaveTeam => {
                self.team = None;
                None
            }
            Command::Lead(on) => {
                if let Some(t) = self.team.as_mut() {
                    t.leading = *on && t.mode == BarrierMode::Leader;
                }
                None
            }
            Command::Publish(a) => {
                let t = self.team.as_ref()?;
                Out::json(t.arrival_key(a.point, a.round), a, Audience::Only(t.to.clone()))
            }
            Command::PublishIn(team, a) => {
                let t = self.team.as_ref()?;
                let (_, to) = t.wide.iter().find(|(p, _)| p == team)?;
                Out::json(Key::TeamSync { team: team.clone(), point: a.point, round: a.round }, a, Audience::Only(to.clone()))
            }
            Command::Release(r) => {
                let t = self.team.as_ref()?;
                Out::json(Key::TeamRelease { team: t.team.clone(), point: r.point, round: r.round }, r, Audience::Only(t.to.clone()))
            }
            Command::Telemetry(t) => match mrmm_proto::encode_telemetry(t) {
                Ok(payload) => Some(Out { key: Key::RobotTelemetry(self.id.clone()), payload, to: Audience::Fleet }),
                Err(e) => {
                    tracing::warn!(robot = %self.id, "telemetry encoding failed: {e}");
                    None
                }
            },
            Command::TrafficReport { map, report } => Out::json(Key::TrafficReport { map: map.clone(), robot: self.id.clone() }, report, Audience::Fleet),
            Command::Reply(_)
            | Command::Refuse(_)
            | Command::Drive(_)
            | Command::Nav(_)
            | Command::Vda(_)
            | Command::KeepCapabilities { .. }
            | Command::Crash => None,
        }
    }

    /// What the robot's machine listens to now: its team's barriers, and the viewers (whom its
    /// telemetry is also for). Its command and info keys are queryables, its teammates and central
    /// liveliness tokens.
    pub fn subscriptions(&self) -> Vec<Sub> {
        let mut subs = vec![Sub::any(Pattern::AllViewers), Sub::any(Pattern::TrafficOrders(self.id.to_string()))];
        if let Some(t) = &self.team {
            subs.extend(t.subscriptions());
        }
        subs
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::egress::heard;
    use mrmm_proto::{SyncArrival, SyncRelease};

    fn join(mode: BarrierMode) -> Command {
        Command::JoinTeam {
            team: "p/ground".into(),
            subteam: "p/ground/ugv".into(),
            barrier: mode,
            members: vec!["r1".into(), "r2".into()],
            scopes: vec![ScopeMembers { team: "p".into(), members: vec!["r1".into(), "r2".into(), "r3".into()] }],
        }
    }

    fn arrival() -> SyncArrival {
        SyncArrival { robot: "r1".into(), epoch: 1, point: 2, round: 3 }
    }

    #[test]
    fn arrivals_go_on_the_team_key_for_the_other_members() {
        let mut l = Links::new("r1");
        assert_eq!(l.egress(&Command::Publish(arrival())), None, "no team: nothing to publish");
        assert_eq!(l.egress(&join(BarrierMode::Mesh)), None);
        let out = l.egress(&Command::Publish(arrival())).expect("published");
        assert_eq!(out.key, Key::TeamSync { team: "p/ground".into(), point: 2, round: 3 });
        assert_eq!(out.to, Audience::Only(vec![Sender::new(Role::Robot, "r2")]));
        let wide = l.egress(&Command::PublishIn("p".into(), arrival())).expect("published");
        assert_eq!(wide.key, Key::TeamSync { team: "p".into(), point: 2, round: 3 });
        assert_eq!(wide.to, Audience::Only(vec![Sender::new(Role::Robot, "r2"), Sender::new(Role::Robot, "r3")]));
        assert_eq!(l.egress(&Command::PublishIn("q".into(), arrival())), None, "not a team of its plan");
        assert_eq!(l.team().map(TeamLinks::widest), Some("p"));
        l.egress(&Command::LeaveTeam);
        assert_eq!(l.egress(&Command::Publish(arrival())), None);
    }

    #[test]
    fn a_leader_hears_arrivals_only_while_it_leads() {
        let mut l = Links::new("r1");
        l.egress(&join(BarrierMode::Leader));
        let out = l.egress(&Command::Publish(arrival())).expect("published");
        let arrive = out.key.to_string();
        assert!(matches!(out.key, Key::TeamArrive { .. }));
        let release = l.egress(&Command::Release(SyncRelease { leader: "r1".into(), epoch: 1, point: 2, round: 3 })).expect("published").key.to_string();
        assert!(!heard(&l.subscriptions(), &arrive, false));
        assert!(heard(&l.subscriptions(), &release, false));
        l.egress(&Command::Lead(true));
        assert!(heard(&l.subscriptions(), &arrive, false));
        assert!(!heard(&l.subscriptions(), &arrive, true), "never its own");
        l.egress(&Command::Lead(false));
        assert!(!heard(&l.subscriptions(), &arrive, false));
    }
}
