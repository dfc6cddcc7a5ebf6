//! A mission host as a node of the driver loop ([`mrmm_core::machine::drive`]): what it hears
//! becomes [`Event`]s of its core; after each decision it follows what the core listens to and
//! (once a second) fetches the maps of the missions it leads or replicates; its chains' state
//! is synced before anything of a step leaves ([`Io`] carries the rest out).

use mrmm_net::inbox::Lanes;
use mrmm_net::{Following, Mesh};
use mrmm_proto::Time;
use tokio::sync::watch;
use tokio_util::sync::CancellationToken;

use super::inputs::{decode, local_changed, Input};
use super::io::Io;
use super::store::Store;
use super::{Event, HostCore, LocalTeam};
use crate::error::ManagerError;

/// Everything a mission host's driver holds around its core.
pub(super) struct Node {
    pub(super) mesh: Mesh,
    pub(super) io: Io,
    pub(super) store: Option<Store>,
    pub(super) follow: Following,
    pub(super) lanes: Lanes<Input>,
    pub(super) status: tokio::time::Interval,
    pub(super) tick: tokio::time::Interval,
    /// On a robot's node: its robot's team, as its runtime says.
    pub(super) local: Option<watch::Receiver<LocalTeam>>,
    pub(super) shutdown: CancellationToken,
    pub(super) clock: mrmm_net::clock::Clock,
    /// What the event under way was: telemetry (which changes nothing the core listens to),
    /// the status tick (when the maps are fetched ahead).
    pub(super) telemetry: bool,
    pub(super) status_tick: bool,
}

impl Node {
    async fn heard(&mut self) -> Option<Event> {
        loop {
            let event = tokio::select! {
                _ = self.shutdown.cancelled() => return None,
                _ = self.status.tick() => Event::StatusTick,
                _ = self.tick.tick() => Event::Tick,
                changed = local_changed(&mut self.local) => match changed {
                    Some(team) => Event::LocalTeam(team),
                    None => {
                        self.local = None;
                        continue;
                    }
                },
                i = self.lanes.recv() => match i? {
                    Input::Query(q) => match self.io.query(q).await {
                        Some(e) => e,
                        None => continue,
                    },
                    Input::Sample(s) => match decode(&self.mesh, &s) {
                        Some(e) => e,
                        None => continue,
                    },
                    Input::Event(e) => e,
                },
            };
            return Some(event);
        }
    }
}

impl mrmm_core::machine::Node<HostCore> for Node {
    async fn next(&mut self, _: &HostCore) -> Result<Option<(Time, Event)>, ManagerError> {
        let Some(event) = self.heard().await else { return Ok(None) };
        self.telemetry = matches!(event, Event::Telemetry(_));
        self.status_tick = matches!(event, Event::StatusTick);
        Ok(Some((self.clock.now(), event)))
    }

    /// The maps of every mission this node leads or replicates fetched before a takeover needs
    /// them (central may be gone by then); the subscriptions following what the core listens
    /// to now — before anything of the step is said, so that the answers are heard.
    async fn decided(&mut self, core: &HostCore) -> Result<(), ManagerError> {
        if self.status_tick {
            self.io.prefetch_maps(&core.maps());
        }
        if !self.telemetry {
            self.follow.follow(&core.subscriptions()).await;
        }
        Ok(())
    }
}
