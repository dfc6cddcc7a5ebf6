//! What central does: its commands carried out on the network and on disk — the journal first,
//! replies to the operator's queries held under ids, publications and questions as the core
//! translates them, dry runs off the loop.

use std::collections::HashMap;
use std::time::Duration;

use mrmm_net::net;
use mrmm_net::Mesh;
use mrmm_proto as proto;
use tokio::sync::mpsc;
use zenoh::query::Query;

use super::inputs::Input;
use super::{CentralCore, Command, Event, DRY_RUN_DEADLINE};
use crate::error::ManagerError;
use crate::journal::{now_ms, Journal};
use mrmm_core::central::system::{self, Req, Request};

/// Central's runtime for the driver loop ([`mrmm_core::machine::drive`]): its journal
/// entries committed (fsync) before anything else of their step is done or said; the rest on
/// the network. A journal that cannot be written stops central: it restarts from what is on
/// disk rather than say "ok" about what is not.
impl mrmm_core::machine::Runtime<CentralCore> for super::node::Node {
    type Error = ManagerError;

    async fn persist(&mut self, batch: Vec<Command>) -> Result<(), ManagerError> {
        let events: Vec<_> = batch
            .into_iter()
            .flat_map(|c| match c {
                Command::System(system::Command::Journal(e)) => e,
                _ => Vec::new(),
            })
            .collect();
        match self.journal.as_mut() {
            Some(j) if !events.is_empty() => {
                tokio::task::block_in_place(|| j.append(&events, now_ms())).inspect_err(|e| tracing::error!("{e}: central stops"))?;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    async fn carry(&mut self, c: Command) -> Result<(), ManagerError> {
        self.io.execute(c).await;
        Ok(())
    }
}

/// Answers `mrmm/system/journal?since=SEQ&limit=N` from the database.
pub(super) async fn answer_journal(mesh: &Mesh, journal: Option<&Journal>, q: Query) {
    let result = match (proto::journal::journal_query(q.parameters().as_str()), journal) {
        (Err(e), _) => Err(e),
        (Ok(_), None) => Err("central runs without a state dir: it keeps no journal".to_string()),
        (Ok((since, limit)), Some(j)) => tokio::task::block_in_place(|| j.page(since, limit)).map_err(|e| e.to_string()),
    };
    match result.and_then(|p| serde_json::to_value(p).map_err(|e| e.to_string())) {
        Ok(v) => mesh.reply_json(&q, &v).await,
        Err(e) => mesh.reply_error(&q, &e).await,
    }
}

/// The I/O half: operator queries held under ids, and requests to robots and hosts.
pub(super) struct Io {
    mesh: Mesh,
    timeout: Duration,
    queries: HashMap<u64, Query>,
    next: u64,
    tx: mpsc::UnboundedSender<Input>,
}

impl Io {
    pub(super) fn new(mesh: Mesh, timeout: Duration, tx: mpsc::UnboundedSender<Input>) -> Io {
        Io { mesh, timeout, queries: HashMap::new(), next: 0, tx }
    }

    pub(super) fn hold(&mut self, q: Query) -> u64 {
        let id = self.next;
        self.next += 1;
        self.queries.insert(id, q);
        id
    }

    /// Decodes an operator query into a typed request; unknown keys and malformed payloads are
    /// answered here.
    pub(super) async fn operator(&mut self, q: Query) -> Option<Event> {
        let payload = net::query_payload(&q);
        let request = Request::decode(q.key_expr().as_str(), &payload);
        match request {
            Ok(request) => Some(Event::System(system::Event::Operator { req: Req::Query(self.hold(q)), request })),
            Err(e) => {
                self.mesh.reply_error(&q, &e).await;
                None
            }
        }
    }

    /// Runs `ask` in the background and hands its answer to the loop as an event.
    fn spawn<F>(&self, ask: F)
    where
        F: std::future::Future<Output = system::Event> + Send + 'static,
    {
        let tx = self.tx.clone();
        tokio::spawn(async move {
            let _ = tx.send(Input::Event(ask.await));
        });
    }

    pub(super) async fn execute(&mut self, c: Command) {
        if let Some(out) = mrmm_core::central::egress(&c) {
            return crate::edge::publish(&self.mesh, out).await;
        }
        if let Command::Traffic(mrmm_core::traffic::authority::Command::Blocked { map, robot, by }) = &c {
            tracing::warn!(%robot, ?by, map = %&map[..8.min(map.len())], "blocked in traffic");
        }
        let Command::System(c) = c else { return };
        if let Some(ask) = system::asks::ask(&c) {
            let (mesh, timeout) = (self.mesh.clone(), self.timeout);
            return self.spawn(async move {
                let key = ask.key.to_string();
                let result = crate::edge::answer_of(&mesh, &ask, timeout).await;
                ask.then.answer(&key, result)
            });
        }
        match c {
            system::Command::Reply { req, result } => {
                let Req::Query(id) = req else { return };
                let Some(q) = self.queries.remove(&id) else {
                    return;
                };
                match result {
                    Ok(v) => self.mesh.reply_json(&q, &v).await,
                    Err(e) => self.mesh.reply_err(&q, &e).await,
                }
            }
            system::Command::Refused(r) => self.mesh.refused(&r),
            system::Command::RollCall => {
                let mesh = self.mesh.clone();
                let patterns = [proto::Pattern::AllRobotsAlive, proto::Pattern::AllHostsAlive];
                self.spawn(async move { system::Event::RollCall(crate::edge::roll_call(&mesh, &patterns).await) })
            }
            // Published above.
            system::Command::Chain { .. } => {}
            // Committed by the runtime before anything else of its step.
            system::Command::Journal(_) => {}
            system::Command::DryRun(dry) => self.spawn(async move {
                let id = dry.id;
                let run = tokio::task::spawn_blocking(move || dry.run());
                let result = match tokio::time::timeout(DRY_RUN_DEADLINE, run).await {
                    Ok(Ok(r)) => r,
                    Ok(Err(e)) => Err(format!("the dry run failed: {e}")),
                    Err(_) => Err(format!("the dry run took longer than {} s: ask for less", DRY_RUN_DEADLINE.as_secs())),
                };
                system::Event::DryRunDone { id, result }
            }),
            // Asked above.
            system::Command::FetchInfo { .. }
            | system::Command::SendToRobot { .. }
            | system::Command::StartMission { .. }
            | system::Command::Ctl { .. }
            | system::Command::Forward { .. } => {}
        }
    }
}
