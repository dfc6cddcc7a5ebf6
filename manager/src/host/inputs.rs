//! What a mission host hears: queries on its queryables, publications and liveliness changes
//! (translated by the host's own ingress once their seals proved their senders), its own tasks'
//! answers, and its robot's team on a robot node.

use mrmm_core::edge::Proof;
use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto::{self as proto, Key, Pattern};
use tokio::sync::watch;
use zenoh::liveliness::LivelinessToken;
use zenoh::pubsub::Subscriber;
use zenoh::query::{Query, Queryable};
use zenoh::sample::Sample;
use zenoh::Session;

use super::{Event, LocalTeam};
use crate::error::ManagerError;
use mrmm_net::inbox::Inbox;

/// A second host under a name the mesh already knows alive would break the chains' majorities:
/// refused with one line, as a bad name is.
pub(super) async fn check_name(session: &Session, node: &str) -> Result<(), ManagerError> {
    proto::validate_id(node).map_err(|e| ManagerError::Config(format!("mission host name: {e}")))?;
    if net::already_alive(session, &Key::HostAlive(node.into()).to_string(), net::NAME_CHECK_TIMEOUT).await? {
        return Err(ManagerError::NameTaken(format!("mission host {node:?} is already alive on the mesh; give every host and robot its own name")));
    }
    Ok(())
}

/// What the host declares for as long as it runs: its start queryable, the liveliness it watches
/// (hosts, robots, planner services; on their own inbox), and its own token, declared last.
pub(super) struct Held {
    _start: Queryable<()>,
    _subs: Vec<Subscriber<()>>,
    _token: LivelinessToken,
}

pub(super) async fn declare(session: &Session, node: &str, live: &Inbox<Input>, net: &Inbox<Input>) -> Result<Held, ManagerError> {
    let t = net.clone();
    let start = session
        .declare_queryable(Key::HostStart(node.into()).to_string())
        .callback(move |q| {
            t.push(Input::Query(q));
        })
        .await
        .map_err(ManagerError::zenoh)?;
    let mut subs = Vec::new();
    for pattern in [Pattern::AllHostsAlive, Pattern::AllRobotsAlive, Pattern::AllPlannersAlive] {
        subs.push(live.liveliness(session, pattern.to_string(), Input::Sample).await?);
    }
    let token = session.liveliness().declare_token(Key::HostAlive(node.into()).to_string()).await.map_err(ManagerError::zenoh)?;
    Ok(Held { _start: start, _subs: subs, _token: token })
}

/// What the Zenoh callbacks and spawned tasks hand the loop.
pub(super) enum Input {
    /// A query on one of our queryables.
    Query(Query),
    Sample(Sample),
    Event(Event),
}

/// The next team of this node's robot; `None` once the robot runtime is gone (or there is none).
pub(super) async fn local_changed(local: &mut Option<watch::Receiver<LocalTeam>>) -> Option<LocalTeam> {
    match local {
        Some(rx) => match rx.changed().await {
            Ok(()) => Some(rx.borrow_and_update().clone()),
            Err(_) => None,
        },
        None => std::future::pending().await,
    }
}

/// A publication or liveliness change as the core's event, translated by the host's own ingress
/// once the seal proved its sender; `None` (refusals recorded, the rest logged) otherwise.
pub(super) fn decode(mesh: &Mesh, s: &Sample) -> Option<Event> {
    let proof = mrmm_core::mission::host::sealed(s.key_expr().as_str()).map(|what| (what, Proof::Own));
    mesh.hear(s, proof, mrmm_core::mission::host::ingress)
}
