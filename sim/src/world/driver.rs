//! The production driver's step ([`mrmm_core::machine`]) over the simulation's runtimes: what
//! central and the mission hosts persist goes to their simulated disks, the rest into the world
//! (publications, replies, questions). Each runtime checks the driver's order: nothing of a step
//! leaves its node before what the step persists is written.

use std::future::Future;
use std::pin::pin;
use std::task::{Context, Poll, Waker};

use mrmm_core::central::{self, CentralCore};
use mrmm_core::machine::Runtime;
use mrmm_core::mission::host::{self, HostCore};
use mrmm_core::robot::{self, Robot};

use super::World;

/// Runs a step of the driver to its end: the simulation's runtimes never wait.
pub(super) fn run<F: Future<Output = Result<(), String>>>(step: F) -> Result<(), String> {
    match pin!(step).poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(r) => r,
        Poll::Pending => Err("a step of the driver waited on the simulation's runtime, which never makes it wait".into()),
    }
}

/// Central's node in the world, for one step.
pub(super) struct OnCentral<'w> {
    world: &'w mut World,
    node: usize,
    /// The step has journal entries, and they are not written yet.
    unwritten: bool,
}

impl<'w> OnCentral<'w> {
    pub(super) fn new(world: &'w mut World, node: usize, journaled: bool) -> Self {
        OnCentral { world, node, unwritten: journaled }
    }
}

impl Runtime<CentralCore> for OnCentral<'_> {
    type Error = String;

    async fn persist(&mut self, batch: Vec<central::Command>) -> Result<(), String> {
        for c in batch {
            self.world.central_command(self.node, c)?;
        }
        self.unwritten = false;
        Ok(())
    }

    async fn carry(&mut self, c: central::Command) -> Result<(), String> {
        if self.unwritten {
            return Err(format!("central carried out {} before its step's journal entries were written", describe(&c)));
        }
        self.world.central_command(self.node, c)
    }
}

/// A mission host's node in the world, for one step.
pub(super) struct OnHost<'w> {
    world: &'w mut World,
    node: usize,
    /// The step has chain state to persist, and it is not written yet.
    unwritten: bool,
}

impl<'w> OnHost<'w> {
    pub(super) fn new(world: &'w mut World, node: usize, persists: bool) -> Self {
        OnHost { world, node, unwritten: persists }
    }
}

impl Runtime<HostCore> for OnHost<'_> {
    type Error = String;

    async fn persist(&mut self, batch: Vec<host::Command>) -> Result<(), String> {
        for c in batch {
            self.world.host_command(self.node, c)?;
        }
        self.unwritten = false;
        Ok(())
    }

    async fn carry(&mut self, c: host::Command) -> Result<(), String> {
        if self.unwritten {
            let name = &self.world.nodes[self.node].name;
            let what: String = format!("{c:?}").chars().take(80).collect();
            return Err(format!("{name} carried out {what} before its step's chain state was written"));
        }
        self.world.host_effect(self.node, c)
    }
}

/// A robot's node in the world, for one step.
pub(super) struct OnRobot<'w> {
    world: &'w mut World,
    node: usize,
    /// The step keeps capabilities, and they are not written yet.
    unwritten: bool,
    /// The robot crashed: nothing more of the step happens.
    crashed: bool,
}

impl<'w> OnRobot<'w> {
    pub(super) fn new(world: &'w mut World, node: usize, persists: bool) -> Self {
        OnRobot { world, node, unwritten: persists, crashed: false }
    }
}

impl Runtime<Robot> for OnRobot<'_> {
    type Error = String;

    async fn persist(&mut self, batch: Vec<robot::Command>) -> Result<(), String> {
        for c in batch {
            self.world.robot_command(self.node, c)?;
        }
        self.unwritten = false;
        Ok(())
    }

    async fn carry(&mut self, c: robot::Command) -> Result<(), String> {
        if self.crashed {
            return Ok(());
        }
        if self.unwritten {
            let name = &self.world.nodes[self.node].name;
            return Err(format!("{name} carried out {} before its step's capabilities were kept", format!("{c:?}").chars().take(80).collect::<String>()));
        }
        self.crashed = !self.world.robot_command(self.node, c)?;
        Ok(())
    }
}

fn describe(c: &central::Command) -> String {
    format!("{c:?}").chars().take(80).collect()
}
