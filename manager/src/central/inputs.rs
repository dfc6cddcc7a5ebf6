//! What central hears: robots' and hosts' liveliness, telemetry and mission status (translated by
//! the system manager's own ingress once their seals proved their senders), the operator API and
//! the advice, and what its seals counted.

use std::time::{Duration, Instant};

use mrmm_core::edge::Proof;
use mrmm_net::Mesh;
use mrmm_proto::{Key, Pattern};
use zenoh::query::Query;
use zenoh::sample::Sample;

use crate::error::ManagerError;
use mrmm_core::central::system;
use mrmm_net::inbox::{self, Inbox, Latest};

/// What the Zenoh callbacks and central's own tasks hand its loop.
pub(super) enum Input {
    Operator(Query),
    Advice(Query),
    Sample(Sample),
    Event(system::Event),
}

/// Central's subscriptions and queryables, kept alive while it runs.
#[derive(Default)]
pub(super) struct Held {
    subs: Vec<zenoh::pubsub::Subscriber<()>>,
    queryables: Vec<zenoh::query::Queryable<()>>,
}

/// Central's inboxes, by priority (see [`mrmm_net::inbox`]).
pub(super) struct Inboxes {
    pub(super) live: Inbox<Input>,
    pub(super) control: Inbox<Input>,
    pub(super) telemetry: Latest<Input>,
}

/// Robots' and hosts' liveliness (on their own inbox: a flood of data must not push out the
/// news that a robot died), telemetry (on its own: shed first), mission status, the operator API
/// and the advice.
pub(super) async fn declare_inputs(session: &zenoh::Session, inboxes: &Inboxes) -> Result<Held, ManagerError> {
    let Inboxes { live, control: net, telemetry } = inboxes;
    let mut held = Held::default();
    for pattern in [Pattern::AllRobotsAlive, Pattern::AllHostsAlive] {
        held.subs.push(live.liveliness(session, pattern.to_string(), Input::Sample).await?);
    }
    for sub in mrmm_core::central::subscriptions() {
        let sub = if sub.expr == Pattern::AllTelemetry.to_string() {
            inbox::subscribe(telemetry, session, sub.expr, Input::Sample).await?
        } else {
            inbox::subscribe(net, session, sub.expr, Input::Sample).await?
        };
        held.subs.push(sub);
    }
    let wraps: [fn(Query) -> Input; 2] = [Input::Operator, Input::Advice];
    for (key, wrap) in [Pattern::SystemAll.to_string(), Key::AgentAdvice.to_string()].into_iter().zip(wraps) {
        let t = net.clone();
        let q = session.declare_queryable(key).callback(move |q| t.push(wrap(q))).await.map_err(ManagerError::zenoh)?;
        held.queryables.push(q);
    }
    Ok(held)
}

/// A publication or liveliness change as the system manager's event, translated by its own
/// ingress once the seal proved its sender; `None` (refusals recorded, the rest logged) otherwise.
pub(super) fn decode(mesh: &Mesh, s: &Sample) -> Option<mrmm_core::central::Event> {
    let proof = mrmm_core::central::sealed(s.key_expr().as_str()).map(|what| (what, Proof::Own));
    mesh.hear(s, proof, mrmm_core::central::ingress)
}

/// What the seals of central's session counted, reported to the system manager: refusals as
/// soon as there are new ones, proofs once a second.
pub(super) struct SealCounts {
    pub(super) refused: u64,
    pub(super) proofs_at: Instant,
}

impl SealCounts {
    pub(super) fn due(&mut self, mesh: &Mesh) -> Vec<system::Event> {
        let mut out = Vec::new();
        let total = mesh.verifier().refused.total();
        if total != self.refused {
            self.refused = total;
            out.push(system::Event::Refusals(mesh.verifier().refused.counts()));
        }
        if self.proofs_at.elapsed() >= Duration::from_secs(1) {
            self.proofs_at = Instant::now();
            out.push(system::Event::Proofs(mesh.verifier().proven.counts()));
        }
        out
    }
}
