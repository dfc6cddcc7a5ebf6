//! The Zenoh side of a robot's team membership: its member token, the members' liveliness, and
//! the barrier subscriptions its machine's links ask for ([`TeamLinks::subscriptions`]: its own
//! team's as its barrier mode runs them, the wider teams' of its plan) — declared here exactly as
//! the simulations route them.

use mrmm_core::edge::Proof;
use mrmm_core::robot::{Event, Robot, TeamLinks};
use mrmm_net::inbox::Inbox;
use mrmm_net::{Following, Mesh};
use mrmm_proto::{Key, Pattern};
use tokio::sync::{mpsc, Mutex};
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;
use zenoh::Session;

use super::QUEUE;
use crate::error::PeerError;

/// The Zenoh side of team membership.
pub(super) struct TeamLink {
    /// Its member token's key, and the widest team whose members' tokens it follows: a new plan
    /// of the same team keeps the link (no token flap for the teammates).
    member: String,
    widest: String,
    _token: LivelinessToken,
    /// Membership tokens of the widest team the plan has barriers with.
    _members: Subscriber<()>,
    members_rx: Mutex<mpsc::Receiver<Sample>>,
    /// The barrier subscriptions, all into one queue (a full queue drops what comes, as the
    /// barriers re-publish while they wait). Its own barrier messages are not heard (the robot
    /// counts its own arrivals before publishing them, which also saves a signature check each).
    data: Following,
    rx: Mutex<mpsc::Receiver<Sample>>,
}

impl TeamLink {
    /// Joins the team `links` describes: member token, teammates' liveliness, its subscriptions.
    pub(super) async fn join(session: &Session, id: &str, links: &TeamLinks) -> Result<Self, PeerError> {
        let member = Key::team_member(&links.subteam, id)?;
        let (live, members_rx) = Inbox::new("robot: teammates' liveliness", QUEUE);
        let members = live.liveliness(session, Pattern::TeamMembers(links.widest().to_string()).to_string(), |s| s).await?;
        let (barriers, rx) = Inbox::new("robot: barrier messages", QUEUE);
        let mut data = Following::new(session.clone(), move |s| barriers.push_from(&s.key_expr().clone(), s));
        data.follow(&links.subscriptions()).await;
        // Declared last: once teammates see it, this robot hears their barriers.
        let token = session.liveliness().declare_token(member.to_string()).await.map_err(PeerError::zenoh)?;
        let (member, widest) = (member.to_string(), links.widest().to_string());
        let link = TeamLink { member, widest, _token: token, _members: members, members_rx: Mutex::new(members_rx), data, rx: Mutex::new(rx) };
        Ok(link)
    }

    /// Whether this link serves robot `id` in the team `links` describes as it is: the same member
    /// token, the same teammates' tokens followed.
    pub(super) fn serves(&self, id: &str, links: &TeamLinks) -> bool {
        Key::team_member(&links.subteam, id).is_ok_and(|m| m.to_string() == self.member) && links.widest() == self.widest
    }

    /// Subscribes to what `links` says the robot hears now, and only that.
    pub(super) async fn follow(&mut self, links: &TeamLinks) {
        self.data.follow(&links.subscriptions()).await;
    }
}

/// The next barrier message of the team; pending when not in a team.
pub(super) async fn recv_data(team: &Option<TeamLink>) -> Sample {
    match team.as_ref() {
        Some(t) => match t.rx.lock().await.recv().await {
            Some(s) => s,
            None => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}

/// The next change of a teammate's liveliness; pending when not in a team.
pub(super) async fn recv_members(team: &Option<TeamLink>) -> Sample {
    match team.as_ref() {
        Some(t) => match t.members_rx.lock().await.recv().await {
            Some(s) => s,
            None => std::future::pending().await,
        },
        None => std::future::pending().await,
    }
}

/// A sealed team message (an arrival or a release) as the robot's event: its seal proven here,
/// the rest translated by the robot's own ingress (a forged one is refused and recorded, a
/// malformed one dropped).
pub(super) fn heard(mesh: &Mesh, robot: &Robot, s: &Sample) -> Option<Event> {
    let what = mrmm_core::robot::sealed(s.key_expr().as_str());
    mesh.hear(s, Some((what, Proof::Own)), |m| robot.ingress(m))
}
