//! A robot's node as a deputy of its map's traffic authority (`mrmm_core::traffic::deputy`):
//! while the orders its robot drives by name it, the node fetches the map, follows every
//! report and order on it (`mrmm/traffic/<hash>/*/*`) and central's liveliness, and — central
//! away and the orders stopped — takes over and gives the orders itself, sealed as its robot.

use std::time::Duration;

use mrmm_core::traffic::deputy::{Command, Deputy, Event};
use mrmm_net::inbox::{self, Inbox};
use mrmm_net::Mesh;
use mrmm_proto::edge::Proof;
use mrmm_proto::{Key, MapRef, Pattern, Time};
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;
use zenoh::sample::{Sample, SampleKind};

use crate::error::ManagerError;
use crate::maps::MapStore;

/// Reports and orders waiting for the deputy's loop, at most (the oldest dropped beyond).
const QUEUE: usize = 1024;
/// How often the deputy's time passes.
const TICK: Duration = Duration::from_millis(100);
/// Wait between two tries to fetch the map.
const FETCH_RETRY: Duration = Duration::from_secs(1);

/// Runs robot `me`'s deputy on the map `named` says (none: it is no one's deputy) until
/// `shutdown`.
pub async fn serve(
    mesh: Mesh,
    me: String,
    mut named: watch::Receiver<Option<MapRef>>,
    maps: MapStore,
    shutdown: CancellationToken,
) -> Result<(), ManagerError> {
    loop {
        let map = named.borrow_and_update().clone();
        if let Some(map) = map {
            follow(&mesh, &me, &map, &maps, &mut named, &shutdown).await?;
        } else {
            tokio::select! {
                _ = shutdown.cancelled() => return Ok(()),
                r = named.changed() => if r.is_err() { return Ok(()) },
            }
        }
        if shutdown.is_cancelled() || named.has_changed().is_err() {
            return Ok(());
        }
    }
}

/// Whether the robot is no longer this map's deputy (or its runtime stopped).
async fn unnamed(named: &mut watch::Receiver<Option<MapRef>>, map: &MapRef) {
    loop {
        if named.changed().await.is_err() {
            return;
        }
        if named.borrow_and_update().as_ref() != Some(map) {
            return;
        }
    }
}

/// Follows map `map` as its deputy until the robot is no longer named or `shutdown`.
async fn follow(
    mesh: &Mesh,
    me: &str,
    map: &MapRef,
    maps: &MapStore,
    named: &mut watch::Receiver<Option<MapRef>>,
    shutdown: &CancellationToken,
) -> Result<(), ManagerError> {
    let held = loop {
        let got = tokio::select! {
            _ = shutdown.cancelled() => return Ok(()),
            _ = unnamed(named, map) => return Ok(()),
            got = maps.fetch(mesh, map) => got,
        };
        match got {
            Ok(h) => break h,
            Err(e) => tracing::warn!(deputy = %me, map = %map.name, "cannot fetch the map to follow its traffic: {e}"),
        }
        tokio::select! {
            _ = shutdown.cancelled() => return Ok(()),
            _ = tokio::time::sleep(FETCH_RETRY) => {}
        }
    };
    let session = mesh.session().clone();
    let (orders, traffic) = Inbox::new("deputy: traffic", QUEUE);
    let _traffic = inbox::subscribe(&orders, &session, Pattern::MapTraffic(map.hash.clone()).to_string(), |s| s).await?;
    let (live, central) = Inbox::new("deputy: central's liveliness", 16);
    let _central = live.liveliness(&session, Key::HostAlive(mrmm_proto::CENTRAL_HOST.into()).to_string(), |s| s).await?;
    let clock = mrmm_net::clock::Clock::start();
    // Central counts as away until its token is heard (at once, from the history, if it is up):
    // no takeover comes before the deputy followed for a while anyway.
    let mut deputy = Deputy::new(Time::ZERO, me.into(), map.hash.clone(), held.map.clone(), false);
    tracing::info!(deputy = %me, map = %map.name, "following the map's traffic authority as its deputy");
    let mut tick = tokio::time::interval(TICK);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut node = Node { mesh, me, map, named, shutdown, clock, tick, traffic, central };
    let Ok(()) = mrmm_core::machine::drive(&mut deputy, &mut node).await;
    tracing::info!(deputy = %me, map = %map.name, "no longer following the map's traffic");
    Ok(())
}

/// A deputy's node for the driver loop ([`mrmm_core::machine::drive`]): the map's reports and
/// orders, central's liveliness and its own time in; it keeps nothing on disk (a deputy that
/// restarts follows anew); orders and reports on the network, the rest in the log.
struct Node<'a> {
    mesh: &'a Mesh,
    me: &'a str,
    map: &'a MapRef,
    named: &'a mut watch::Receiver<Option<MapRef>>,
    shutdown: &'a CancellationToken,
    clock: mrmm_net::clock::Clock,
    tick: tokio::time::Interval,
    traffic: tokio::sync::mpsc::Receiver<Sample>,
    central: tokio::sync::mpsc::Receiver<Sample>,
}

impl mrmm_core::machine::Node<Deputy> for Node<'_> {
    async fn next(&mut self, deputy: &Deputy) -> Result<Option<(Time, Event)>, Self::Error> {
        loop {
            let event = tokio::select! {
                _ = self.shutdown.cancelled() => return Ok(None),
                _ = unnamed(self.named, self.map) => return Ok(None),
                _ = self.tick.tick() => Event::Tick,
                s = self.traffic.recv() => {
                    let Some(s) = s else { return Ok(None) };
                    let what = if Key::parse(s.key_expr().as_str()).is_some_and(|k| matches!(k, Key::TrafficOrder { .. })) { "traffic order" } else { "traffic report" };
                    match self.mesh.hear(&s, Some((what, Proof::Own)), |m| deputy.ingress(m)) {
                        Some(ev) => ev,
                        None => continue,
                    }
                }
                s = self.central.recv() => {
                    let Some(s) = s else { return Ok(None) };
                    Event::Central(s.kind() == SampleKind::Put)
                }
            };
            return Ok(Some((self.clock.now(), event)));
        }
    }
}

impl mrmm_core::machine::Runtime<Deputy> for Node<'_> {
    type Error = std::convert::Infallible;

    async fn persist(&mut self, _: Vec<Command>) -> Result<(), Self::Error> {
        Ok(())
    }

    async fn carry(&mut self, c: Command) -> Result<(), Self::Error> {
        let (me, map) = (self.me, &self.map.name);
        if let Some(out) = Deputy::egress(&c) {
            crate::edge::publish(self.mesh, out).await;
            return Ok(());
        }
        match c {
            Command::TookOver { incarnation } => {
                tracing::warn!(deputy = %me, %map, incarnation, "central away and no traffic orders: this robot's node gives them now")
            }
            Command::SteppedDown { incarnation } => tracing::info!(deputy = %me, %map, incarnation, "traffic orders given by another again: following"),
            Command::Authority(mrmm_core::traffic::authority::Command::Blocked { robot, by, .. }) => {
                tracing::warn!(%robot, ?by, %map, "blocked in traffic")
            }
            Command::Authority(_) => {}
        }
        Ok(())
    }
}
