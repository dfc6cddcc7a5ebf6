//! Queries between secure meshes: tagged once the server is known, asked again signed when the
//! server cannot prove the tag (its certificate was re-issued); answers to tagged queries name
//! the server's certificate by id, asked again signed when the asker no longer holds it.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use super::*;
use crate::security::seal::CertRef;
use crate::security::{pki, Role};
use mrmm_proto::Key;

fn scratch() -> PathBuf {
    static N: AtomicU32 = AtomicU32::new(0);
    let p = std::env::temp_dir().join(format!("mrmm-mesh-{}-{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed)));
    let _ = std::fs::remove_dir_all(&p);
    p
}

async fn node(dir: &Path, mode: Mode, me: Sender, connect: &[String]) -> Mesh {
    let net = NodeNet {
        mode,
        listen: vec!["quic/127.0.0.1:0".into()],
        connect: connect.to_vec(),
        lease_ms: 1000,
        max_message_size: net::DEFAULT_MAX_MESSAGE_SIZE,
        security: Some(SecuritySection::from_dir(dir, &me.id)),
        me: Some(me),
        wire_stats: false,
    };
    Mesh::open(&net).await.expect("a secure mesh")
}

/// A server as mission hosts are: it answers only queries whose seal proves their sender —
/// with the sender's id and whether the query was signed.
fn serve(mesh: Mesh, key: String) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let q = mesh.session().declare_queryable(&key).await.expect("queryable");
        while let Ok(q) = q.recv_async().await {
            match mesh.try_sender_of_query(&q) {
                Ok(from) => {
                    let signed = q.attachment().and_then(|a| crate::security::seal::decode(&a.to_bytes()).ok().map(|s| s.signature.is_some()));
                    mesh.reply_json(&q, &(from.id, signed == Some(true))).await
                }
                Err(r) => mesh.refuse_unproven("test query", &q, &r).await,
            }
        }
    })
}

async fn ask(asker: &Mesh, key: &str) -> Result<((String, bool), Sender), QueryError> {
    asker.query::<(String, bool)>(key, None, Duration::from_secs(3), |s| s.is(Role::Host, "h1")).await
}

/// Until the server's queryable is reachable (links and declarations settle).
async fn first_answer(asker: &Mesh, key: &str) -> ((String, bool), Sender) {
    for _ in 0..50 {
        if let Ok(a) = ask(asker, key).await {
            return a;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("the server never answered");
}

/// One more query is answered unsigned, and the server proved it by a tag, not a signature.
async fn tagged_only(asker: &Mesh, server: &Mesh, key: &str, why: &str) {
    let before = server.verifier().proven.counts();
    let (who, _) = ask(asker, key).await.expect("a tagged query is answered");
    assert_eq!(who, ("central".to_string(), false), "{why}");
    let after = server.verifier().proven.counts();
    assert_eq!(after.get("signature"), before.get("signature"), "{why}: {after:?}");
    assert_eq!(after.get("tag").copied().unwrap_or(0), before.get("tag").copied().unwrap_or(0) + 1, "{after:?}");
    assert!(matches!(answer_cert(asker, key, false).await, CertRef::Id(_)), "{why}: the answer to a tagged query carried the certificate");
    assert!(matches!(answer_cert(asker, key, true).await, CertRef::Der(_)), "the answer to a signed query named the certificate by id");
}

/// How the answer to a query from `asker` (tagged for the known server; signed as well if
/// `sign`) refers to the server's certificate.
async fn answer_cert(asker: &Mesh, key: &str, sign: bool) -> CertRef<'static> {
    let known = asker.verifier().pairs().map(|p| p.known_where(|s| s.is(Role::Host, "h1"))).unwrap_or_default();
    let att = asker.seal_tagged(key, &[], &known, sign);
    let replies = asker.session().get(key).timeout(Duration::from_secs(3)).attachment(att).await.expect("get");
    let reply = replies.recv_async().await.expect("an answer");
    let att = reply.result().expect("not an error").attachment().expect("sealed").to_bytes().to_vec();
    let seal = crate::security::seal::decode(&att).expect("a seal");
    match seal.cert.expect("a certificate") {
        CertRef::Id(id) => CertRef::Id(id),
        CertRef::Der(_) => CertRef::Der(&[]),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn queries_are_tagged_once_the_server_is_known_and_signed_again_after_a_reissue() {
    let dir = scratch();
    pki::init(&dir).expect("ca");
    pki::issue(&dir, Role::Central, "central", &[], 1).expect("central");
    pki::issue(&dir, Role::Host, "h1", &[], 1).expect("h1");
    let asker = node(&dir, Mode::Router, Sender::new(Role::Central, "central"), &[]).await;
    let ep = net::listening_endpoints(asker.session()).await;
    let key = Key::HostStart("h1".into()).to_string();

    let server = node(&dir, Mode::Peer, Sender::new(Role::Host, "h1"), &ep).await;
    let task = serve(server.clone(), key.clone());
    // Not known yet: signed. The answer teaches the asker the server's key.
    let (who, from) = first_answer(&asker, &key).await;
    assert_eq!((who, from), (("central".to_string(), true), Sender::new(Role::Host, "h1")));
    // Known now: tagged only — the server checks a tag, no signature.
    tagged_only(&asker, &server, &key, "a query to a known server was signed").await;
    // The asker no longer holds the server's certificate (its cache was cleared): the answer
    // naming it by id is refused as unseen, the query asked again signed and answered.
    asker.verifier().forget_certificates();
    let (who, _) = ask(&asker, &key).await.expect("answered after the signed retry");
    assert_eq!(who, ("central".to_string(), true), "answered without the signed retry");
    let refused = asker.verifier().refused.counts();
    assert!(refused.get("unseen_certificate").copied().unwrap_or(0) >= 1, "{refused:?}");
    tagged_only(&asker, &server, &key, "the asker did not prove the certificate again").await;
    task.abort();
    server.close().await;

    // The server comes back with a re-issued certificate (a new key): the asker's tag is for
    // the old one. Refused as unproven, asked again signed, answered — and tagged after that.
    for f in ["h1.crt", "h1.key"] {
        std::fs::remove_file(dir.join(f)).expect("the old certificate");
    }
    pki::issue(&dir, Role::Host, "h1", &[], 1).expect("h1 again");
    let server = node(&dir, Mode::Peer, Sender::new(Role::Host, "h1"), &ep).await;
    let task = serve(server.clone(), key.clone());
    let (who, _) = first_answer(&asker, &key).await;
    assert_eq!(who, ("central".to_string(), true), "answered without the signed retry");
    let refused = server.verifier().refused.counts();
    assert!(refused.get("unaddressed").copied().unwrap_or(0) >= 1, "the stale tag was not refused: {refused:?}");
    let before = server.verifier().proven.counts();
    assert!(before.get("signature").copied().unwrap_or(0) >= 1, "{before:?}");
    tagged_only(&asker, &server, &key, "the asker did not learn the new key").await;
    task.abort();
    server.close().await;
    asker.close().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A server that holds a query past its timeout: Zenoh ends the query with its own error reply
/// (`Timeout`), which is no answer (retryable, "no answer on … within … ms"), not a server's
/// refusal reading "Timeout" — what `cannot create mission patrol-1: Timeout` was.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_query_nobody_answers_in_time_is_no_answer_not_a_refusal() {
    let open = |connect: Vec<String>| {
        let net = NodeNet {
            mode: Mode::Peer,
            listen: vec!["tcp/127.0.0.1:0".into()],
            connect,
            lease_ms: 1000,
            max_message_size: net::DEFAULT_MAX_MESSAGE_SIZE,
            security: None,
            me: None,
            wire_stats: false,
        };
        async move { Mesh::open(&net).await.expect("a mesh") }
    };
    let server = open(vec![]).await;
    let ep = net::listening_endpoints(server.session()).await;
    let asker = open(ep).await;
    let key = Key::SystemMaps.to_string();
    let q = server.session().declare_queryable(&key).await.expect("queryable");
    let held = tokio::spawn(async move {
        let mut kept = Vec::new();
        while let Ok(query) = q.recv_async().await {
            kept.push(query);
        }
    });
    let mut last = None;
    for _ in 0..50 {
        let started = std::time::Instant::now();
        let r = asker.query::<serde_json::Value>(&key, None, Duration::from_millis(300), |_| true).await;
        let e = r.expect_err("nobody answers");
        // Until the queryable is known the query ends at once with nobody to ask; then it
        // reaches the server and ends at its timeout.
        if started.elapsed() >= Duration::from_millis(250) {
            last = Some(e);
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let e = last.expect("a query that reached the silent server");
    assert!(matches!(e, QueryError::NoAnswer { .. }) && e.retryable(), "{e:?}");
    let e = net::query::<serde_json::Value>(asker.session(), &key, None, Duration::from_millis(300)).await.expect_err("nobody answers");
    assert!(matches!(e, QueryError::NoAnswer { .. }), "{e:?}");
    held.abort();
    asker.close().await;
    server.close().await;
}
