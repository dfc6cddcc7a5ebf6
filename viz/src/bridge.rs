//! The Zenoh → Rerun bridge.

use std::net::ToSocketAddrs;
use std::path::PathBuf;
use std::time::Duration;

use mrmm_core::observer::{self, Seen};
use mrmm_net::{Following, Mesh};
use mrmm_proto::traffic::TrafficView;
use mrmm_proto::{self as proto, Key};
use tokio_util::sync::CancellationToken;
use zenoh::sample::Sample;

use crate::view::View;
use crate::VizError;

/// Messages waiting for the bridge's loop, at most (a flood drops what comes).
const QUEUE: usize = 4096;
/// How often to check that a viewer is reachable (`--connect`).
const PROBE_EVERY: Duration = Duration::from_secs(5);
/// How often central's traffic is asked for.
const TRAFFIC_EVERY: Duration = Duration::from_secs(1);

/// Where the recording goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Sink {
    /// A running viewer, e.g. `rerun+http://127.0.0.1:9876/proxy`.
    Connect(String),
    /// An `.rrd` file.
    Save(PathBuf),
    /// Spawn a viewer (needs `rerun` on PATH).
    Spawn,
}

fn rr(e: impl Into<mrmm_proto::BoxError>) -> VizError {
    VizError::Rerun(e.into())
}

/// Streams the fleet seen on `mesh` to `sink` until `shutdown`; flushes before returning. Only
/// what its proven sender may publish is drawn.
pub async fn run(mesh: Mesh, sink: Sink, shutdown: CancellationToken) -> Result<(), VizError> {
    let session = mesh.session().clone();
    let mut probe = match &sink {
        Sink::Connect(url) => Some(Probe { addr: viewer_addr(url)?, reachable: None }),
        _ => None,
    };
    let rec = recording(&sink)?;
    // What an observer hears (telemetry, missions' status, advice, barriers), in one queue.
    let (tx, mut heard) = tokio::sync::mpsc::channel::<Sample>(QUEUE);
    let mut follow = Following::new(session.clone(), move |s| {
        let _ = tx.try_send(s);
    });
    follow.follow(&observer::subscriptions()).await;
    if let Err(e) = crate::map::blueprint().send(&rec, rerun::blueprint::BlueprintActivation::default()) {
        tracing::warn!("the viewer's layout was not sent: {e}");
    }
    let mut view = View::new(rec.clone());
    let mut maps = Maps::new(mesh.clone());
    // Announces itself to the robots, which tag their telemetry for it (otherwise it could
    // check only their signed messages: one per `TELEMETRY_SIGN_MS`).
    let mut hello = tokio::time::interval(Duration::from_millis(proto::VIEWER_HELLO_MS));
    let hello_key = Key::Viewer(mesh.me().id.clone()).to_string();
    let mut probe_tick = tokio::time::interval(PROBE_EVERY);
    // Central's traffic, asked once a second (one query at a time, off the loop).
    let mut traffic_tick = tokio::time::interval(TRAFFIC_EVERY);
    let mut asking: tokio::task::JoinSet<Option<Vec<TrafficView>>> = tokio::task::JoinSet::new();
    loop {
        tokio::select! {
            _ = shutdown.cancelled() => break,
            _ = hello.tick(), if mesh.is_secure() => mesh.put(&hello_key, b"{}".to_vec(), zenoh::bytes::Encoding::APPLICATION_JSON).await,
            _ = probe_tick.tick(), if probe.is_some() => {
                if let Some(p) = probe.as_mut() {
                    p.check().await;
                }
            }
            _ = traffic_tick.tick(), if asking.is_empty() => {
                let m = mesh.clone();
                asking.spawn(async move {
                    let key = Key::SystemTraffic.to_string();
                    m.query::<Vec<TrafficView>>(&key, None, TRAFFIC_EVERY, |s| s.role == proto::Role::Central).await.ok().map(|(v, _)| v)
                });
            }
            Some(done) = asking.join_next(), if !asking.is_empty() => {
                // (Each view carries its vertices' points; the maps are drawn under the names
                // the missions on them give.)
                if let Ok(Some(views)) = done {
                    view.traffic(&views, &maps.graphs);
                }
            }
            Some((r, map)) = maps.rx.recv() => maps.arrived(&view, r, map),
            s = heard.recv() => {
                let Some(s) = s else { break };
                match seen(&mesh, &s) {
                    Some(Seen::Telemetry(t)) => view.robot(&t),
                    Some(Seen::Mission(m)) => {
                        if let Some(r) = m.map.clone() {
                            maps.want(r);
                        }
                        view.mission(&m)
                    }
                    Some(Seen::Advice(a)) => view.advice(&a),
                    Some(Seen::Arrival { team, arrival }) => view.sync(&team, &arrival),
                    Some(Seen::Release { team, release }) => view.release(&team, &release),
                    None => {}
                }
            }
        }
    }
    finish(&rec, &sink)
}

/// The recording stream `sink` takes.
fn recording(sink: &Sink) -> Result<rerun::RecordingStream, VizError> {
    let builder = rerun::RecordingStreamBuilder::new("mrmm_fleet");
    Ok(match sink {
        Sink::Save(p) => builder.save(p).map_err(rr)?,
        Sink::Spawn => builder.spawn().map_err(rr)?,
        Sink::Connect(url) => builder.connect_grpc_opts(url.clone()).map_err(|e| VizError::Config(format!("viewer URL {url:?}: {e}")))?,
    })
}

/// Flushes what was drawn; a viewer that never came is said, not a failure of the bridge.
fn finish(rec: &rerun::RecordingStream, sink: &Sink) -> Result<(), VizError> {
    match (rec.flush_blocking(), sink) {
        (Ok(()), _) => Ok(()),
        (Err(e), Sink::Connect(url)) => {
            tracing::warn!("the fleet view was not delivered to {url}: {e}");
            eprintln!("mrmm viz: no Rerun viewer took the recording at {url}");
            Ok(())
        }
        (Err(e), _) => Err(rr(e)),
    }
}

type Fetched = (proto::MapRef, Result<mrmm_maps::Map, String>);

/// Maps arrive from the fleet (fetched by hash in the background), each drawn once; graph maps
/// kept for traffic.
struct Maps {
    mesh: Mesh,
    tx: tokio::sync::mpsc::UnboundedSender<Fetched>,
    rx: tokio::sync::mpsc::UnboundedReceiver<Fetched>,
    asked: std::collections::BTreeSet<String>,
    graphs: std::collections::BTreeMap<String, std::sync::Arc<mrmm_maps::NavGraph>>,
}

impl Maps {
    fn new(mesh: Mesh) -> Maps {
        let (tx, rx) = tokio::sync::mpsc::unbounded_channel();
        Maps { mesh, tx, rx, asked: Default::default(), graphs: Default::default() }
    }

    /// Fetches map `r` unless it was asked for already.
    fn want(&mut self, r: proto::MapRef) {
        if self.asked.insert(r.hash.clone()) {
            fetch_map(self.mesh.clone(), r, self.tx.clone());
        }
    }

    fn arrived(&mut self, view: &View, r: proto::MapRef, map: Result<mrmm_maps::Map, String>) {
        match map {
            Ok(map) => {
                if let Err(e) = crate::map::log(&view.rec, &r.name, &map) {
                    tracing::warn!("rerun log of map {}: {e}", r.name);
                }
                if let mrmm_maps::Map::Graph(g) = map {
                    self.graphs.insert(r.hash.clone(), std::sync::Arc::new(g));
                }
            }
            Err(e) => {
                // Asked again at the mission's next status.
                tracing::warn!(map = %r.name, "cannot draw the map yet: {e}");
                self.asked.remove(&r.hash);
            }
        }
    }
}

/// What the viewer heard, its sender proven as an observer can (only the signed messages of a
/// team's barrier stream), translated with the one policy; refusals recorded, the rest logged.
fn seen(mesh: &Mesh, s: &Sample) -> Option<Seen> {
    let proof = observer::proof(s.key_expr().as_str())?;
    mesh.hear(s, Some(proof), observer::observe)
}

/// Fetches map `r` from the fleet and hands it to the loop.
fn fetch_map(mesh: Mesh, r: proto::MapRef, to: tokio::sync::mpsc::UnboundedSender<Fetched>) {
    tokio::spawn(async move {
        let loaded = match mrmm_net::map::fetch(&mesh, &r).await {
            Ok(bytes) => mrmm_maps::Bundle::decode(&r.name, &bytes).and_then(|b| b.load()).map(|(_, m)| m).map_err(|e| e.to_string()),
            Err(e) => Err(e),
        };
        let _ = to.send((r, loaded));
    });
}

/// Whether the viewer the bridge connects to is there, said when it changes.
struct Probe {
    addr: String,
    reachable: Option<bool>,
}

impl Probe {
    async fn check(&mut self) {
        let addr = &self.addr;
        let ok = tokio::time::timeout(Duration::from_secs(1), tokio::net::TcpStream::connect(addr)).await.is_ok_and(|r| r.is_ok());
        if self.reachable != Some(ok) {
            if ok {
                tracing::info!("Rerun viewer reachable at {addr}");
            } else {
                tracing::warn!("no Rerun viewer at {addr} yet; buffering and retrying (start one with `rerun`)");
                eprintln!("mrmm viz: no Rerun viewer at {addr} yet; retrying every {} s", PROBE_EVERY.as_secs());
            }
            self.reachable = Some(ok);
        }
    }
}

/// `host:port` of a `rerun+http://host:port/proxy` URL, checked to resolve.
fn viewer_addr(url: &str) -> Result<String, VizError> {
    let rest = url.split("://").nth(1).ok_or_else(|| VizError::Config(format!("viewer URL {url:?}: expected rerun+http://HOST:PORT/proxy")))?;
    let addr = rest.split('/').next().unwrap_or(rest).to_string();
    addr.to_socket_addrs().map_err(|e| VizError::Config(format!("viewer URL {url:?}: {e}")))?;
    Ok(addr)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viewer_urls() {
        assert_eq!(viewer_addr("rerun+http://127.0.0.1:9876/proxy").expect("ok"), "127.0.0.1:9876");
        assert!(viewer_addr("127.0.0.1:9876").is_err());
    }
}
