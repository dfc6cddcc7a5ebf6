//! The robot as a node of the driver loop ([`mrmm_core::machine::drive`]): its [`Inputs`] give
//! the events, [`Io`] carries the commands out (a reply to the query its event came with), and
//! after each step the node tells the other services of its process what changed in the robot
//! — its mission host the team, its traffic deputy the map it deputises on.

use mrmm_proto::{MapRef, Time};
use tokio::sync::watch;
use zenoh::query::Query;

use super::inputs::Inputs;
use super::io::Io;
use super::LocalTeam;
use crate::error::PeerError;
use mrmm_core::robot::{Event, Robot};

/// Everything a robot's driver holds around its machine.
pub(super) struct Node {
    pub(super) inputs: Inputs,
    pub(super) io: Io,
    /// The operator's query the event under way came with, answered by its reply.
    pub(super) query: Option<Query>,
    pub(super) clock: mrmm_net::clock::Clock,
    /// The mission host of this process, told whom the robot trusts for which mission.
    pub(super) team: Option<watch::Sender<LocalTeam>>,
    /// The traffic deputy of this process, told the map whose authority names the robot.
    pub(super) deputy: Option<watch::Sender<Option<MapRef>>>,
    /// A tick is due at once (a VDA 5050 vehicle's robot, after an event that may give its
    /// vehicle something to do).
    pub(super) tick_now: bool,
}

impl mrmm_core::machine::Node<Robot> for Node {
    async fn next(&mut self, robot: &Robot) -> Result<Option<(Time, Event)>, PeerError> {
        if std::mem::take(&mut self.tick_now) {
            return Ok(Some((self.clock.now(), Event::Tick)));
        }
        let Some((event, query)) = self.inputs.next(robot, &mut self.io).await else { return Ok(None) };
        self.query = query;
        // A vehicle's robot ticks slowly (there is nothing to integrate: the vehicle drives
        // itself), and at once after anything that may give it a goal or take one (a grant, a
        // command, the vehicle's state), so that what it is to be sent goes out now.
        self.tick_now = self.io.vda.is_some() && !matches!(event, Event::Tick | Event::TelemetryDue);
        Ok(Some((self.clock.now(), event)))
    }

    async fn stepped(&mut self, robot: &Robot) -> Result<(), PeerError> {
        self.query = None;
        if self.io.crashed {
            // No goodbye: whoever runs the robot drops its session as a crash would.
            return Err(PeerError::Crashed(self.io.id.clone()));
        }
        if let Some(tx) = &self.team {
            let now: LocalTeam = robot.team();
            tx.send_if_modified(|t| replace(t, now));
        }
        if let Some(tx) = &self.deputy {
            let id = self.io.id.as_str();
            let now = robot.traffic().filter(|g| g.deputies().iter().any(|d| d.as_str() == id)).map(|g| g.map().clone());
            tx.send_if_modified(|d| replace(d, now));
        }
        Ok(())
    }
}

/// Puts `now` in `held` if it differs; whether it did.
fn replace<T: PartialEq>(held: &mut T, now: T) -> bool {
    let changed = *held != now;
    if changed {
        *held = now;
    }
    changed
}
