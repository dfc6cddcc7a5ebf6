//! The contract between a pure machine and the driver that runs it: [`Machine::handle`] decides,
//! [`carry_out`] carries the decision out through a [`Runtime`] — the production one (Zenoh,
//! redb, the chain store: `mrmm-manager`) or the simulation's (`mrmm-sim`), which run this same
//! code — and [`drive`] is the loop of every production node around the two.
//!
//! # Order
//! Every command has a typed effect ([`Effect`]): what the node must **persist**, what it
//! **publishes**, **asks** another node, **replies** to a question it was asked, and what stays
//! in the node (**local**: its body, its declarations, its log, a job off its loop whose result
//! comes back as an event). Everything one step persists is written and synced before anything
//! of that step leaves the node, in one batch, in the machine's order (raft-rs's `Ready`: a node
//! that said "ok" must still know it after a crash). The rest follows in the machine's order.
//! No machine sets a timer: time reaches it as events (ticks) its node makes. A runtime that
//! cannot persist stops the step, and its node: it must restart from what is on disk rather than
//! say what is not there.

use std::future::Future;

use mrmm_proto::Time;

/// A pure state machine: no I/O, no clock; time comes with each event.
pub trait Machine {
    type Event;
    type Command;

    fn handle(&mut self, now: Time, event: Self::Event) -> Vec<Self::Command>;

    /// What `command` does (the simulation checks that it does nothing else).
    fn effect(command: &Self::Command) -> Effect;
}

/// What a command does, to the driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Written and synced before anything of its step leaves the node.
    Persist,
    /// A publication on a key (whoever subscribes hears it).
    Publish,
    /// A question to another node; its answer (or its failure) comes back as an event.
    Ask,
    /// The answer to a question this node was asked (or the question let go).
    Reply,
    /// What stays in the node: its body, its declarations, its log, a job off its loop.
    Local,
}

/// One step's commands in the contract's order.
#[derive(Debug, Clone, PartialEq)]
pub struct Ready<C> {
    /// What must be durable first, in the machine's order.
    pub persist: Vec<C>,
    /// The rest, in the machine's order.
    pub carry: Vec<C>,
}

impl<C> Ready<C> {
    /// Sorts a machine's commands by [`Machine::effect`], keeping their order within each kind.
    pub fn of<M: Machine<Command = C>>(commands: Vec<C>) -> Ready<C> {
        let (persist, carry) = commands.into_iter().partition(|c| M::effect(c) == Effect::Persist);
        Ready { persist, carry }
    }
}

/// Where a machine's commands take effect.
pub trait Runtime<M: Machine> {
    type Error;

    /// Writes and syncs `batch` (never empty); nothing of the step is carried out before it
    /// returns `Ok`.
    fn persist(&mut self, batch: Vec<M::Command>) -> impl Future<Output = Result<(), Self::Error>>;

    /// Carries out one command (publish, reply, ask, start a timer).
    fn carry(&mut self, command: M::Command) -> impl Future<Output = Result<(), Self::Error>>;
}

/// A node around its machine: where its events come from (and when), what it does between the
/// machine's decision and its effects, and after them. With [`Runtime`] it is everything one
/// node's driver is; [`drive`] is the loop every node runs.
pub trait Node<M: Machine>: Runtime<M> {
    /// The node's next event for `machine` and the time it is handled at, once one comes;
    /// `None` stops the node. Input that needs no decision of the machine (a refused sender, a
    /// malformed payload, a question the node answers alone) is dealt with here.
    fn next(&mut self, machine: &M) -> impl Future<Output = Result<Option<(Time, M::Event)>, Self::Error>>;

    /// Between the machine's decision and its effects: what the node follows of the machine's
    /// new state before anything of the step leaves (its subscriptions, say).
    fn decided(&mut self, machine: &M) -> impl Future<Output = Result<(), Self::Error>> {
        let _ = machine;
        async { Ok(()) }
    }

    /// After the step's effects: what the node tells others of the machine's new state.
    fn stepped(&mut self, machine: &M) -> impl Future<Output = Result<(), Self::Error>> {
        let _ = machine;
        async { Ok(()) }
    }
}

/// The driver loop — the one of every node (central, mission hosts, robots, traffic deputies):
/// the node's next event, the machine's decision, the node's look at it, the decision carried
/// out in the contract's order, the node's look after. Returns when the node has no more
/// events, or with the first error of the node (a persist that failed stops it).
pub async fn drive<M: Machine, N: Node<M>>(machine: &mut M, node: &mut N) -> Result<(), N::Error> {
    while let Some((now, event)) = node.next(machine).await? {
        let commands = machine.handle(now, event);
        node.decided(machine).await?;
        carry_out::<M, N>(node, commands).await?;
        node.stepped(machine).await?;
    }
    Ok(())
}

/// Carries out commands a machine decided, in the contract's order: what must be durable
/// first, then the rest. [`drive`] takes this step for every event of a node; the simulation,
/// which interleaves many machines in one world, takes it for each of their decisions.
pub async fn carry_out<M: Machine, R: Runtime<M>>(runtime: &mut R, commands: Vec<M::Command>) -> Result<(), R::Error> {
    let Ready { persist, carry } = Ready::of::<M>(commands);
    if !persist.is_empty() {
        runtime.persist(persist).await?;
    }
    for c in carry {
        runtime.carry(c).await?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;
    use std::pin::pin;
    use std::task::{Context, Poll, Waker};

    /// Echoes its event's numbers as commands; negative ones are to persist.
    struct Echo;

    impl Machine for Echo {
        type Event = Vec<i32>;
        type Command = i32;
        fn handle(&mut self, _now: Time, event: Vec<i32>) -> Vec<i32> {
            event
        }
        fn effect(c: &i32) -> Effect {
            if *c < 0 {
                Effect::Persist
            } else {
                Effect::Publish
            }
        }
    }

    #[derive(Default)]
    struct Log {
        done: Vec<String>,
        fail_persist: bool,
    }

    impl Runtime<Echo> for Log {
        type Error = String;
        async fn persist(&mut self, batch: Vec<i32>) -> Result<(), String> {
            if self.fail_persist {
                return Err("disk full".into());
            }
            self.done.push(format!("persist {batch:?}"));
            Ok(())
        }
        async fn carry(&mut self, c: i32) -> Result<(), String> {
            self.done.push(format!("carry {c}"));
            Ok(())
        }
    }

    fn ready<F: Future>(f: F) -> F::Output {
        match pin!(f).poll(&mut Context::from_waker(Waker::noop())) {
            Poll::Ready(v) => v,
            Poll::Pending => panic!("the test runtime never waits"),
        }
    }

    #[test]
    fn persists_come_first_in_one_batch_then_the_rest_in_order() {
        let mut log = Log::default();
        ready(carry_out::<Echo, _>(&mut log, Echo.handle(at(0.0), vec![1, -1, 2, -2, 3]))).unwrap();
        assert_eq!(log.done, ["persist [-1, -2]", "carry 1", "carry 2", "carry 3"]);
    }

    #[test]
    fn nothing_is_carried_out_when_the_persist_fails() {
        let mut log = Log { fail_persist: true, ..Log::default() };
        assert_eq!(ready(carry_out::<Echo, _>(&mut log, Echo.handle(at(0.0), vec![1, -1, 2]))), Err("disk full".to_string()));
        assert!(log.done.is_empty(), "{:?}", log.done);
    }

    /// A node of scripted events around [`Echo`], noting what the loop does when.
    struct Script {
        log: Log,
        events: Vec<Vec<i32>>,
    }

    impl Runtime<Echo> for Script {
        type Error = String;
        async fn persist(&mut self, batch: Vec<i32>) -> Result<(), String> {
            self.log.persist(batch).await
        }
        async fn carry(&mut self, c: i32) -> Result<(), String> {
            self.log.carry(c).await
        }
    }

    impl Node<Echo> for Script {
        async fn next(&mut self, _: &Echo) -> Result<Option<(Time, Vec<i32>)>, String> {
            Ok((!self.events.is_empty()).then(|| (Time::ZERO, self.events.remove(0))))
        }
        async fn decided(&mut self, _: &Echo) -> Result<(), String> {
            self.log.done.push("decided".into());
            Ok(())
        }
        async fn stepped(&mut self, _: &Echo) -> Result<(), String> {
            self.log.done.push("stepped".into());
            Ok(())
        }
    }

    #[test]
    fn the_loop_looks_at_the_decision_before_its_effects_and_after_them() {
        let mut node = Script { log: Log::default(), events: vec![vec![1, -1], vec![2]] };
        ready(drive(&mut Echo, &mut node)).unwrap();
        assert_eq!(node.log.done, ["decided", "persist [-1]", "carry 1", "stepped", "decided", "carry 2", "stepped"]);
    }

    #[test]
    fn the_loop_stops_at_a_failed_persist() {
        let mut node = Script { log: Log { fail_persist: true, ..Log::default() }, events: vec![vec![-1, 1], vec![2]] };
        assert_eq!(ready(drive(&mut Echo, &mut node)), Err("disk full".to_string()));
        assert_eq!(node.log.done, ["decided"]);
        assert_eq!(node.events, [vec![2]], "no event after the failed step is taken");
    }

    #[test]
    fn a_step_without_persists_writes_nothing() {
        let mut log = Log::default();
        ready(carry_out::<Echo, _>(&mut log, Echo.handle(at(0.0), vec![4, 5]))).unwrap();
        assert_eq!(log.done, ["carry 4", "carry 5"]);
    }
}
