//! The Zenoh side of a robot's team membership: its member token, its barrier subscriptions
//! (its own team's and the wider teams' of its plan), and the members' liveliness.

use mrmm_proto::{BarrierMode, Key, Pattern, Role, Sender};
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Session;

use super::QUEUE;
use crate::error::PeerError;

/// The Zenoh side of team membership: member token, barrier and membership subscriptions.
pub(super) struct TeamLink {
    pub(super) team: String,
    mode: BarrierMode,
    /// The other members of the plan: whom this robot's barrier messages are for.
    pub(super) to: Vec<Sender>,
    _token: LivelinessToken,
    /// Teammates' arrivals: every member's under [`BarrierMode::Mesh`], the leader's only under
    /// [`BarrierMode::Leader`].
    arrivals: Option<Subscriber<RingChannelHandler<Sample>>>,
    /// The leader's releases ([`BarrierMode::Leader`]).
    releases: Option<Subscriber<RingChannelHandler<Sample>>>,
    /// Membership tokens of the widest team the plan has barriers with.
    members: Subscriber<RingChannelHandler<Sample>>,
    /// The wider teams' barriers: each one's path and whom its arrivals are for.
    pub(super) wide: Vec<(String, Vec<Sender>)>,
    /// Arrivals at the wider teams' barriers, tagged with the team's path (one subscription per
    /// wider team, kept alive here; a full queue drops, as a ring channel would).
    wide_arrivals: Option<tokio::sync::Mutex<tokio::sync::mpsc::Receiver<(String, Sample)>>>,
    _wide_subs: Vec<Subscriber<()>>,
}

/// Subscribes to teammates' samples on `pattern` (not our own: the robot counts its own
/// arrivals before publishing them, which also saves a signature check each).
async fn team_subscriber(session: &Session, pattern: Pattern) -> Result<Subscriber<RingChannelHandler<Sample>>, PeerError> {
    session
        .declare_subscriber(pattern.to_string())
        .allowed_origin(zenoh::sample::Locality::Remote)
        .with(RingChannel::new(QUEUE))
        .await
        .map_err(PeerError::zenoh)
}

impl TeamLink {
    pub(super) async fn join(
        session: &Session,
        id: &str,
        team: &str,
        subteam: &str,
        mode: BarrierMode,
        plan_members: &[String],
        scopes: &[mrmm_proto::ScopeMembers],
    ) -> Result<Self, PeerError> {
        let member = Key::team_member(subteam, id)?;
        // Wider teams contain the robot's own: the shortest path is the widest.
        let widest = scopes.iter().map(|s| s.team.as_str()).chain([team]).min_by_key(|t| t.len()).unwrap_or(team);
        let members = session
            .liveliness()
            .declare_subscriber(Pattern::TeamMembers(widest.to_string()).to_string())
            .history(true)
            .with(RingChannel::new(QUEUE))
            .await
            .map_err(PeerError::zenoh)?;
        let (arrivals, releases) = match mode {
            BarrierMode::Mesh => (Some(team_subscriber(session, Pattern::TeamSync(team.to_string())).await?), None),
            // Arrivals once the plan says this robot leads (Command::Lead).
            BarrierMode::Leader => (None, Some(team_subscriber(session, Pattern::TeamRelease(team.to_string())).await?)),
        };
        let token = session.liveliness().declare_token(member.to_string()).await.map_err(PeerError::zenoh)?;
        let others = |ms: &[String]| ms.iter().filter(|m| m.as_str() != id).map(|m| Sender::new(Role::Robot, m.clone())).collect::<Vec<_>>();
        let to = others(plan_members);
        let (mut wide, mut subs, mut wide_arrivals) = (Vec::new(), Vec::new(), None);
        if !scopes.is_empty() {
            let (tx, rx) = tokio::sync::mpsc::channel(QUEUE);
            for sc in scopes {
                let (tx, path) = (tx.clone(), sc.team.clone());
                let sub = session
                    .declare_subscriber(Pattern::TeamSync(sc.team.clone()).to_string())
                    .allowed_origin(zenoh::sample::Locality::Remote)
                    .callback(move |s| {
                        let _ = tx.try_send((path.clone(), s));
                    })
                    .await
                    .map_err(PeerError::zenoh)?;
                subs.push(sub);
                wide.push((sc.team.clone(), others(&sc.members)));
            }
            wide_arrivals = Some(tokio::sync::Mutex::new(rx));
        }
        Ok(TeamLink { team: team.to_string(), mode, to, _token: token, arrivals, releases, members, wide, wide_arrivals, _wide_subs: subs })
    }

    /// Starts (`true`) or stops hearing the team's arrivals as its leader.
    pub(super) async fn lead(&mut self, session: &Session, on: bool) -> Result<(), PeerError> {
        if self.mode != BarrierMode::Leader {
            return Ok(());
        }
        self.arrivals = if on { Some(team_subscriber(session, Pattern::TeamArrive(self.team.clone())).await?) } else { None };
        Ok(())
    }

    /// Where this robot's arrival at (point, round) goes.
    pub(super) fn arrival_key(&self, point: u32, round: u32) -> Key {
        match self.mode {
            BarrierMode::Mesh => Key::TeamSync { team: self.team.clone(), point, round },
            BarrierMode::Leader => Key::TeamArrive { team: self.team.clone(), point, round },
        }
    }
}

/// A subscription of the team link.
#[derive(Clone, Copy)]
pub(super) enum Sub {
    Arrivals,
    Releases,
    Members,
}

/// The next sample of one of the team's subscriptions; pending when not in a team or without it.
pub(super) async fn recv_team(team: &Option<TeamLink>, which: Sub) -> Sample {
    let sub = team.as_ref().and_then(|t| match which {
        Sub::Arrivals => t.arrivals.as_ref(),
        Sub::Releases => t.releases.as_ref(),
        Sub::Members => Some(&t.members),
    });
    match sub {
        Some(sub) => match sub.recv_async().await {
            Ok(s) => s,
            Err(_) => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}

/// The next arrival at a wider team's barrier, with the team's path; pending without any.
pub(super) async fn recv_wide(team: &Option<TeamLink>) -> (String, Sample) {
    match team.as_ref().and_then(|t| t.wide_arrivals.as_ref()) {
        Some(rx) => match rx.lock().await.recv().await {
            Some(x) => x,
            None => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}
