//! The managers' edge, outward, as Zenoh carries it: a machine's publications ([`publish`]) and
//! questions ([`answer_of`]), translated by `mrmm_core` (`egress`, `ask`) as in the simulations.

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
