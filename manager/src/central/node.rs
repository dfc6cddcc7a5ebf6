//! Central as a node of the driver loop ([`mrmm_core::machine::drive`]): what it hears becomes
//! [`Event`]s of its core (the journal's pages and malformed input answered here), its commands
//! are carried out by [`Io`] after the journal's entries are synced, and each step's cost is
//! counted ([`LoopLoad`]).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use mrmm_net::inbox::Lanes;
use mrmm_net::Mesh;
use mrmm_proto::{Key, Time};
use tokio_util::sync::CancellationToken;

use super::inputs::{decode, Input, SealCounts};
use super::io::{answer_journal, Io};
use super::{CentralCore, Event};
use crate::error::ManagerError;
use crate::journal::Journal;
use crate::load::LoopLoad;
use mrmm_core::central::system;

/// Everything central's driver holds around its core.
pub(super) struct Node {
    pub(super) mesh: Mesh,
    pub(super) io: Io,
    pub(super) journal: Option<Journal>,
    pub(super) lanes: Lanes<Input>,
    pub(super) tick: tokio::time::Interval,
    pub(super) seals: SealCounts,
    pub(super) load: LoopLoad,
    pub(super) shutdown: CancellationToken,
    pub(super) clock: mrmm_net::clock::Clock,
    /// Events already due (the seal counts a tick brings), handled before anything new.
    pub(super) due: VecDeque<Event>,
    /// The step under way: its kind, when its event came and when the core had decided.
    pub(super) step: Option<(&'static str, Instant, Duration)>,
}

impl Node {
    /// The next event: one already due, else of the network, the tick or central's own tasks;
    /// `None` at shutdown.
    async fn heard(&mut self) -> Option<Event> {
        loop {
            if let Some(e) = self.due.pop_front() {
                return Some(e);
            }
            let event = tokio::select! {
                _ = self.shutdown.cancelled() => return None,
                _ = self.tick.tick() => {
                    // The seal counts the tick makes due, then the tick, as the core has always
                    // seen them.
                    self.due.extend(self.seals.due(&self.mesh).into_iter().map(Event::System));
                    self.due.push_back(Event::System(system::Event::Tick));
                    continue;
                }
                i = self.lanes.recv() => match i? {
                    Input::Operator(q) if Key::parse(q.key_expr().as_str()) == Some(Key::SystemJournal) => {
                        answer_journal(&self.mesh, self.journal.as_ref(), q).await;
                        continue;
                    }
                    Input::Operator(q) => match self.io.operator(q).await {
                        Some(e) => e,
                        None => continue,
                    },
                    Input::Advice(q) => Event::Advice { query: self.io.hold(q) },
                    Input::Sample(s) => match decode(&self.mesh, &s) {
                        Some(e) => e,
                        None => continue,
                    },
                    Input::Event(e) => Event::System(e),
                },
            };
            return Some(event);
        }
    }
}

impl mrmm_core::machine::Node<CentralCore> for Node {
    async fn next(&mut self, _: &CentralCore) -> Result<Option<(Time, Event)>, ManagerError> {
        let Some(event) = self.heard().await else { return Ok(None) };
        self.step = Some((event.kind(), Instant::now(), Duration::ZERO));
        Ok(Some((self.clock.now(), event)))
    }

    async fn decided(&mut self, _: &CentralCore) -> Result<(), ManagerError> {
        if let Some((_, start, deciding)) = &mut self.step {
            *deciding = start.elapsed();
        }
        Ok(())
    }

    async fn stepped(&mut self, _: &CentralCore) -> Result<(), ManagerError> {
        if let Some((kind, start, deciding)) = self.step.take() {
            self.load.step(kind, deciding, start.elapsed().saturating_sub(deciding));
        }
        Ok(())
    }
}
