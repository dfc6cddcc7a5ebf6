//! The robot's I/O half: what each command of its machine means on the network — replies,
//! team membership and barrier messages, telemetry, ROS 2 goals and twists, what it keeps on disk.

use mrmm_core::egress::{Audience, Out};
use mrmm_core::robot::Links;
use mrmm_net::security::seal::SignCadence;
use mrmm_net::Mesh;
use mrmm_proto::{self as proto, Key, Role, Sender};
use mrmm_ros2::msgs::Twist;
use mrmm_ros2::RosLink;
use zenoh::query::Query;

use super::team::TeamLink;
use mrmm_core::body::nav_goals::NavCommand;
use mrmm_core::robot::viewers::Viewers;
use mrmm_core::robot::{Command, Robot};

/// A robot's telemetry is signed (as well as tagged for the receivers it knows) once in this
/// many milliseconds: receivers it does not know yet check one message in that time (one in ten
/// at the demo's 5 Hz), and a robot streaming faster pays no more signatures for it.
pub const TELEMETRY_SIGN_MS: u64 = 2000;

/// The I/O half: the session, the team subscriptions and the telemetry publisher.
pub(super) struct Io {
    pub(super) mesh: Mesh,
    pub(super) id: String,
    /// Its team as the network sees it (what it publishes on, what it hears).
    pub(super) links: Links,
    pub(super) team: Option<TeamLink>,
    pub(super) publisher: zenoh::pubsub::Publisher<'static>,
    pub(super) telemetry_key: String,
    /// Telemetry messages published (which of them are signed).
    pub(super) telemetry_signs: SignCadence,
    /// Viewers its telemetry is tagged for.
    pub(super) viewers: Viewers,
    /// A ROS 2 body's link.
    pub(super) ros: Option<RosLink>,
    /// A VDA 5050 vehicle's link to its gateway.
    pub(super) vda: Option<super::VdaLink>,
    /// Where the robot keeps what must survive a restart.
    pub(super) state_dir: Option<std::path::PathBuf>,
    /// Ordered to crash (a simulated robot): the runtime stops at once.
    pub(super) crashed: bool,
}

/// The robot's runtime for the driver loop ([`mrmm_core::machine::drive`]): a reply answers the
/// query its step's event came with.
impl mrmm_core::machine::Runtime<Robot> for super::node::Node {
    type Error = crate::error::PeerError;

    /// What the robot keeps across a restart; one it cannot keep is said in the log (the change
    /// holds until the robot restarts).
    async fn persist(&mut self, batch: Vec<Command>) -> Result<(), Self::Error> {
        for c in batch {
            let (Command::KeepCapabilities { configured, now }, Some(dir)) = (c, &self.io.state_dir) else { continue };
            if let Err(e) = crate::kept::save(dir, &configured, &now) {
                tracing::warn!(robot = %self.io.id, "capabilities not kept across a restart: {e}");
            }
        }
        Ok(())
    }

    async fn carry(&mut self, c: Command) -> Result<(), Self::Error> {
        self.io.execute(c, self.query.as_ref()).await;
        Ok(())
    }
}

impl Io {
    pub(super) async fn execute(&mut self, c: Command, query: Option<&Query>) {
        // What it means on the network, as the simulations route it: the links keep up with the
        // team and say what goes out on which key, for whom.
        let out = self.links.egress(&c);
        match c {
            Command::Reply(result) => match (query, result) {
                (Some(q), Ok(ack)) => self.mesh.reply_json(q, &ack).await,
                (Some(q), Err(e)) => {
                    tracing::warn!(robot = %self.id, "refused command: {e}");
                    self.mesh.reply_error(q, &e).await;
                }
                (None, _) => {}
            },
            Command::Refuse(e) => {
                self.mesh.verifier().refused.record(
                    "robot command",
                    &mrmm_net::security::Refusal::NotEntitled {
                        proven: query.and_then(|q| self.mesh.try_sender_of_query(q).ok()).unwrap_or_else(|| Sender::new(Role::Operator, "unknown")),
                        what: e.clone(),
                    },
                );
                if let Some(q) = query {
                    self.mesh.reply_err(q, &proto::ErrorReply::coded(proto::ErrorCode::Refused, e)).await;
                }
            }
            Command::Crash => self.crashed = true,
            Command::JoinTeam { .. } | Command::LeaveTeam => self.rejoin().await,
            Command::Lead(on) => self.lead(on).await,
            // Published below.
            Command::Publish(_) | Command::PublishIn(..) | Command::Release(_) | Command::Telemetry(_) | Command::TrafficReport { .. } => {}
            Command::Nav(NavCommand::Send { id, x, y, yaw }) => {
                if let Some(ros) = &self.ros {
                    tracing::info!(robot = %self.id, x, y, "Nav2 goal sent");
                    ros.send_goal(id, x, y, yaw);
                }
            }
            Command::Nav(NavCommand::Cancel(id)) => {
                if let Some(ros) = &self.ros {
                    ros.cancel_goal(id);
                }
            }
            Command::Vda(out) => {
                if let Some(link) = &self.vda {
                    link.send(&self.id, out);
                }
            }
            // Written by the runtime before anything else of its step.
            Command::KeepCapabilities { .. } => {}
            Command::Drive(v) => {
                if let Some(ros) = self.ros.as_mut() {
                    if let Err(e) = ros.send_twist(Twist::planar(v.v, v.omega)).await {
                        tracing::warn!(robot = %self.id, "cmd_vel publication failed: {e}");
                    }
                }
            }
        }
        if let Some(out) = out {
            self.publish(out).await;
        }
    }

    /// Puts `out` on the network: telemetry through its publisher, barrier messages sealed for
    /// their receivers.
    async fn publish(&mut self, out: Out) {
        match (&out.key, out.to) {
            (Key::RobotTelemetry(_), _) => self.publish_telemetry(out.payload).await,
            (key, Audience::Only(to)) => {
                let encoding = mrmm_net::encoding_of(&out.payload);
                self.mesh.put_for(&key.to_string(), out.payload, encoding, &to).await
            }
            (key, Audience::Fleet) => {
                let encoding = mrmm_net::encoding_of(&out.payload);
                self.mesh.put(&key.to_string(), out.payload, encoding).await
            }
        }
    }

    /// Telemetry, tagged for central, mission hosts and teammates (managers of its mission on
    /// robots) it knows and current viewers; one message per [`TELEMETRY_SIGN_MS`] signed as
    /// well, for everyone else (a host that takes its mission over before it knows that host).
    async fn publish_telemetry(&mut self, bytes: Vec<u8>) {
        let team = self.links.team().map(|t| t.to.as_slice()).unwrap_or_default();
        let now = mrmm_net::mesh::now_ms();
        let sign = self.telemetry_signs.due(now);
        let viewers = &self.viewers;
        let seal = self.mesh.seal_for_known(
            &self.telemetry_key,
            &bytes,
            |s| matches!(s.role, Role::Central | Role::Host) || team.contains(s) || viewers.is_current(now, s),
            sign,
        );
        if let Err(e) = self.publisher.put(bytes).attachment(seal).await {
            tracing::warn!("telemetry publication failed: {e}");
        }
    }

    /// A new plan's team (a fresh member token, and the teammates' liveliness heard from the
    /// start), or none.
    async fn rejoin(&mut self) {
        let Some(links) = self.links.team().cloned() else {
            self.team = None;
            return;
        };
        // The same team again (a hand-over, a replan): its token stays up, only what it hears
        // follows the new plan — teammates see no member go and come back.
        if let Some(t) = self.team.as_mut().filter(|t| t.serves(&self.id, &links)) {
            t.follow(&links).await;
            return;
        }
        self.team = None;
        match TeamLink::join(self.mesh.session(), &self.id, &links).await {
            Ok(link) => self.team = Some(link),
            Err(e) => tracing::warn!(robot = %self.id, "cannot join team {}: {e}", links.team),
        }
    }

    /// Starts (`true`) or stops hearing the team's arrivals as its leader.
    async fn lead(&mut self, on: bool) {
        let (Some(t), Some(links)) = (self.team.as_mut(), self.links.team()) else { return };
        t.follow(links).await;
        tracing::info!(robot = %self.id, team = %links.team, on, "leads the team's barriers");
    }
}
