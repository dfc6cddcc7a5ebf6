//! The robot's inputs: its queryables, subscriptions, liveliness and timers, each turned into
//! an event of its machine — through the robot's own ingress for everything from the network
//! (`mrmm_core::robot::Robot::ingress`), after the seal proved its sender.

use std::time::Duration;

use mrmm_net::inbox::{self, Inbox};
use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto::{self as proto, Key, Pattern};
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

use super::io::Io;
use super::ros::{recv_ros, RosCounts};
use super::team::{heard, recv_data, recv_members};
use super::{FLEET_CHECK_PERIOD, QUEUE};
use crate::error::PeerError;
use mrmm_core::robot::viewers::{Heard, MAX_VIEWERS};
use mrmm_core::robot::{Event, Incoming, Robot};

/// Where the robot's events come from, besides its team's subscriptions (in [`Io`]).
pub(super) struct Inputs {
    session: Session,
    mesh: Mesh,
    id: String,
    shutdown: CancellationToken,
    /// Its queryables and subscriptions (each into an [`Inbox`]: a full one drops what comes).
    _queryables: [Queryable<()>; 2],
    _subscribers: [Subscriber<()>; 3],
    info_q: mpsc::Receiver<Query>,
    cmd_q: mpsc::Receiver<Query>,
    /// Viewers announcing themselves: the robot's telemetry is tagged for them too.
    viewers: mpsc::Receiver<Sample>,
    /// Orders of the traffic authorities (`mrmm/traffic/*/order/<id>`).
    traffic: mpsc::Receiver<Sample>,
    /// Central's liveliness: while it is gone, nobody admits this robot to missions.
    central: mpsc::Receiver<Sample>,
    physics: tokio::time::Interval,
    telemetry: tokio::time::Interval,
    /// Whether the robot's session has a link to any other fleet node (a ROS 2 body stops
    /// without one); checked a few times a second.
    fleet_check: tokio::time::Interval,
    fleet_up: bool,
    endpoints: Vec<String>,
    /// What a ROS 2 body sent that could not be taken, counted.
    ros: RosCounts,
}

fn interval(period: Duration) -> tokio::time::Interval {
    let mut i = tokio::time::interval(period);
    i.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    i
}

impl Inputs {
    /// Declares the robot's queryables (info, commands), then the subscriptions it hears; it
    /// ticks every `period` and is due telemetry `telemetry_hz` times a second.
    pub(super) async fn declare(
        mesh: &Mesh,
        id: &str,
        (period, telemetry_hz): (Duration, f64),
        endpoints: Vec<String>,
        shutdown: CancellationToken,
    ) -> Result<Inputs, PeerError> {
        let session = mesh.session().clone();
        let (info, info_q) = Inbox::new("robot: info queries", QUEUE);
        let info_d = inbox::queryable(&info, &session, Key::RobotInfo(id.into()).to_string(), |q| q).await?;
        let (cmd, cmd_q) = Inbox::new("robot: commands", QUEUE);
        let cmd_d = inbox::queryable(&cmd, &session, Key::RobotCmd(id.into()).to_string(), |q| q).await?;
        let (view, viewers) = Inbox::new("robot: viewers", QUEUE);
        let view_d = inbox::subscribe(&view, &session, Pattern::AllViewers.to_string(), |s| s).await?;
        let (orders, traffic) = Inbox::new("robot: traffic orders", QUEUE);
        let orders_d = inbox::subscribe(&orders, &session, Pattern::TrafficOrders(id.to_string()).to_string(), |s| s).await?;
        let (live, central) = Inbox::new("robot: central's liveliness", QUEUE);
        let central_d = live.liveliness(&session, Key::HostAlive(proto::CENTRAL_HOST.into()).to_string(), |s| s).await?;
        Ok(Inputs {
            mesh: mesh.clone(),
            session,
            id: id.to_string(),
            shutdown,
            _queryables: [info_d, cmd_d],
            _subscribers: [view_d, orders_d, central_d],
            info_q,
            cmd_q,
            viewers,
            traffic,
            central,
            physics: interval(period),
            telemetry: interval(Duration::from_secs_f64(1.0 / telemetry_hz)),
            fleet_check: interval(FLEET_CHECK_PERIOD),
            fleet_up: true,
            endpoints,
            ros: RosCounts::new(id),
        })
    }

    /// The robot's next event (with the query it answers, if any); `None` once it shuts down.
    /// What needs no event of the machine (its info, viewers' announcements, refused or
    /// malformed input) is handled here.
    pub(super) async fn next(&mut self, robot: &Robot, io: &mut Io) -> Option<(Event, Option<Query>)> {
        loop {
            let got: (Event, Option<Query>) = tokio::select! {
                _ = self.shutdown.cancelled() => return None,
                _ = self.physics.tick() => (Event::Tick, None),
                _ = self.telemetry.tick() => (Event::TelemetryDue, None),
                _ = self.fleet_check.tick(), if io.ros.is_some() => {
                    let info = self.session.info();
                    let up = info.routers_zid().await.next().is_some() || info.peers_zid().await.next().is_some();
                    if up == self.fleet_up {
                        continue;
                    }
                    self.fleet_up = up;
                    tracing::warn!(robot = %self.id, up, "fleet link changed");
                    (Event::FleetLink(up), None)
                }
                state = super::vda::recv(&mut io.vda) => (Event::Vda(state), None),
                input = recv_ros(&io.ros) => match self.ros.event(input) {
                    Some(ev) => (ev, None),
                    None => continue,
                },
                q = self.info_q.recv() => {
                    let q = q?;
                    self.mesh.reply_json(&q, &robot.info(self.endpoints.clone())).await;
                    continue;
                }
                q = self.cmd_q.recv() => {
                    let q = q?;
                    match self.command(robot, &q).await {
                        Some(ev) => (ev, Some(q)),
                        None => continue,
                    }
                }
                s = recv_data(&io.team) => match heard(&self.mesh, robot, &s) {
                    Some(ev) => (ev, None),
                    None => continue,
                },
                s = self.traffic.recv() => {
                    let s = s?;
                    match heard(&self.mesh, robot, &s) {
                        Some(ev) => (ev, None),
                        None => continue,
                    }
                }
                s = self.viewers.recv() => {
                    let s = s?;
                    self.viewer(&s, io);
                    continue;
                }
                s = self.central.recv() => match liveliness(robot, &s?) {
                    Some(ev) => (ev, None),
                    None => continue,
                },
                s = recv_members(&io.team) => match liveliness(robot, &s) {
                    Some(ev) => (ev, None),
                    None => continue,
                },
            };
            return Some(got);
        }
    }

    /// A viewer announcing itself: the robot's telemetry is tagged for it from now on.
    fn viewer(&self, s: &Sample, io: &mut Io) {
        let Some(from) = self.mesh.sender_of("viewer announcement", s) else { return };
        let now = mrmm_net::mesh::now_ms();
        let new = !io.viewers.is_current(now, &from);
        match io.viewers.heard(now, from.clone()) {
            // A new viewer has not proven this robot's certificate yet: the next message carries
            // it (the tagged ones between signatures only name it).
            Heard::Kept if new => io.telemetry_signs.sign_next(),
            Heard::Kept => {}
            Heard::NotAViewer => self.mesh.refuse("announce a viewer", &from),
            Heard::Full => tracing::debug!(robot = %self.id, viewer = %from, "viewer not tagged for: {MAX_VIEWERS} others are current"),
        }
    }

    /// A command query: its seal proven, then translated by the robot's ingress; refused ones
    /// are answered here.
    async fn command(&mut self, robot: &Robot, q: &Query) -> Option<Event> {
        let from = match self.mesh.try_sender_of_query(q) {
            Ok(from) => from,
            Err(r) => {
                self.mesh.refuse_unproven("robot command", q, &r).await;
                return None;
            }
        };
        match robot.ingress(Incoming { key: q.key_expr().as_str(), payload: &net::query_payload(q), put: true, from: Some(&from) }) {
            Ok(ev) => Some(ev),
            Err(e) => {
                tracing::warn!(robot = %self.id, "refused command: {e}");
                self.mesh.reply_error(q, &e.to_string()).await;
                None
            }
        }
    }
}

/// A liveliness token (a teammate's, central's) as the robot's event.
fn liveliness(robot: &Robot, s: &Sample) -> Option<Event> {
    match robot.ingress(Incoming { key: s.key_expr().as_str(), payload: &[], put: s.kind() == SampleKind::Put, from: None }) {
        Ok(ev) => Some(ev),
        Err(e) => {
            tracing::warn!("ignored token {}: {e}", s.key_expr());
            None
        }
    }
}
