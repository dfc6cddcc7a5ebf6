//! The managers' edge, outward, as Zenoh carries it: a machine's publications ([`publish`]),
//! questions ([`answer_of`]) and roll calls ([`roll_call`]), translated by `mrmm_core` (`egress`,
//! `ask`, `roll_call`) as in the simulations.

use std::time::Duration;

use mrmm_core::ask::Ask;
use mrmm_core::egress::{Audience, Out};
use mrmm_net::Mesh;
use serde_json::Value;

use mrmm_core::Failure;

/// Puts a machine's publication on the network, sealed (for its receivers, if it names them).
pub async fn publish(mesh: &Mesh, out: Out) {
    let key = out.key.to_string();
    match out.to {
        Audience::Fleet => {
            let encoding = mrmm_net::encoding_of(&out.payload);
            mesh.put(&key, out.payload, encoding).await
        }
        Audience::Only(to) => {
            let encoding = mrmm_net::encoding_of(&out.payload);
            mesh.put_for(&key, out.payload, encoding, &to).await
        }
    }
}

/// Asks `ask`'s question and waits (its own timeout, else `default`) for an answer from one of
/// its answerers: its JSON, or why there is none.
pub async fn answer_of<T>(mesh: &Mesh, ask: &Ask<T>, default: Duration) -> Result<Value, Failure> {
    let timeout = ask.timeout_s.map_or(default, Duration::from_secs_f64);
    let key = ask.key.to_string();
    mesh.query::<Value>(&key, ask.payload.clone(), timeout, |s| ask.answerer.admits(s)).await.map(|(v, _)| v).map_err(Failure::from)
}

/// The liveliness tokens up on `patterns`, as the network answers a liveliness query on each
/// ([`mrmm_core::roll_call`]): an answer that took the whole [`ANSWER_S`] may miss some, and is
/// marked incomplete.
///
/// [`ANSWER_S`]: mrmm_core::roll_call::ANSWER_S
pub async fn roll_call(mesh: &Mesh, patterns: &[mrmm_proto::Pattern]) -> Result<mrmm_core::roll_call::Present, String> {
    let timeout = Duration::from_secs_f64(mrmm_core::roll_call::ANSWER_S);
    let mut present = mrmm_core::roll_call::Present::default();
    for pattern in patterns {
        let started = std::time::Instant::now();
        let replies = mesh.session().liveliness().get(pattern.to_string()).timeout(timeout).await.map_err(|e| e.to_string())?;
        while let Ok(reply) = replies.recv_async().await {
            match reply.result() {
                Ok(sample) => present.take(sample.key_expr().as_str()),
                Err(_) => present.complete = false,
            }
        }
        if started.elapsed() >= timeout {
            present.complete = false;
        }
    }
    Ok(present)
}
