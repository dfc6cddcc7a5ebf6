//! The production driver's step ([`mrmm_core::machine`]) over the simulation's runtime: what a
//! node persists goes to its simulated disk, the rest into the world (publications, replies,
//! questions). The runtime checks the driver's order — nothing of a step leaves its node before
//! what the step persists is written — and each command's typed effect: one the machine says
//! does not publish (or ask) publishes (or asks) nothing.

use std::future::Future;
use std::marker::PhantomData;
use std::pin::pin;
use std::task::{Context, Poll, Waker};

use mrmm_core::central::{self, CentralCore};
use mrmm_core::machine::{self, Effect, Machine, Runtime};
use mrmm_core::mission::host::{self, HostCore};
use mrmm_core::robot::{self, Robot};

use super::World;

/// A machine of the world's nodes, as its driver carries its commands out there.
pub(super) trait OnNode: Machine {
    /// What a carry before the step's persists broke: "its step's … written".
    const KEPT: &'static str;
    /// Writes a command to persist to node `node`'s disk.
    fn persist(world: &mut World, node: usize, c: Self::Command) -> Result<(), String>;
    /// Carries out a command on node `node`; `Ok(false)`: the node went down (its last command).
    fn carry(world: &mut World, node: usize, c: Self::Command) -> Result<bool, String>;
}

/// Carries out one step's commands of node `node`'s machine `M` through the production driver.
pub(super) fn carry_out<M: OnNode>(world: &mut World, node: usize, commands: Vec<M::Command>) -> Result<(), String>
where
    M::Command: std::fmt::Debug,
{
    let unwritten = commands.iter().any(|c| M::effect(c) == Effect::Persist);
    let mut on = On::<M> { world, node, unwritten, down: false, machine: PhantomData };
    let polled = pin!(machine::carry_out::<M, _>(&mut on, commands)).poll(&mut Context::from_waker(Waker::noop()));
    match polled {
        Poll::Ready(r) => r,
        Poll::Pending => Err("a step of the driver waited on the simulation's runtime, which never makes it wait".into()),
    }
}

/// A node of the world, for one step of its machine `M`.
struct On<'w, M> {
    world: &'w mut World,
    node: usize,
    /// The step has something to persist, and it is not written yet.
    unwritten: bool,
    /// The node went down: nothing more of the step happens.
    down: bool,
    machine: PhantomData<M>,
}

impl<M: OnNode> Runtime<M> for On<'_, M>
where
    M::Command: std::fmt::Debug,
{
    type Error = String;

    async fn persist(&mut self, batch: Vec<M::Command>) -> Result<(), String> {
        for c in batch {
            M::persist(self.world, self.node, c)?;
        }
        self.unwritten = false;
        Ok(())
    }

    async fn carry(&mut self, c: M::Command) -> Result<(), String> {
        if self.down {
            return Ok(());
        }
        if self.unwritten {
            return Err(format!("{} carried out {} before {}", self.world.nodes[self.node].name, brief(&c), M::KEPT));
        }
        let effect = M::effect(&c);
        let before = (self.world.published, self.world.next_qid);
        // Written before the command is gone, for the violation's message: its first 80
        // characters only (formatting a whole plan on every command would slow every seed).
        let what = brief(&c);
        self.down = !M::carry(self.world, self.node, c)?;
        let (published, asked) = (self.world.published > before.0, self.world.next_qid > before.1);
        if (published && effect != Effect::Publish) || (asked && effect != Effect::Ask) {
            let did = if published { "published" } else { "asked" };
            return Err(format!("{} {did} on {what}, a command whose effect is {effect:?}", self.world.nodes[self.node].name));
        }
        Ok(())
    }
}

/// The first 80 characters of `c`'s `Debug` form; the formatting stops there.
fn brief(c: &impl std::fmt::Debug) -> String {
    use std::fmt::Write;
    struct Upto80(String);
    impl Write for Upto80 {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            let room = 80 - self.0.chars().count();
            self.0.extend(s.chars().take(room));
            if self.0.chars().count() >= 80 {
                return Err(std::fmt::Error);
            }
            Ok(())
        }
    }
    let mut out = Upto80(String::new());
    let _ = write!(out, "{c:?}");
    out.0
}

impl OnNode for CentralCore {
    const KEPT: &'static str = "its step's journal entries were written";

    fn persist(world: &mut World, node: usize, c: central::Command) -> Result<(), String> {
        world.central_command(node, c)
    }

    fn carry(world: &mut World, node: usize, c: central::Command) -> Result<bool, String> {
        world.central_command(node, c).map(|()| true)
    }
}

impl OnNode for HostCore {
    const KEPT: &'static str = "its step's chain state was written";

    fn persist(world: &mut World, node: usize, c: host::Command) -> Result<(), String> {
        world.host_command(node, c)
    }

    fn carry(world: &mut World, node: usize, c: host::Command) -> Result<bool, String> {
        world.host_effect(node, c).map(|()| true)
    }
}

impl OnNode for Robot {
    const KEPT: &'static str = "its step's capabilities were kept";

    fn persist(world: &mut World, node: usize, c: robot::Command) -> Result<(), String> {
        world.robot_command(node, c).map(|_| ())
    }

    fn carry(world: &mut World, node: usize, c: robot::Command) -> Result<bool, String> {
        world.robot_command(node, c)
    }
}
