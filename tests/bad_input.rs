//! Bad input over the wire to a running central (real processes): requests that once made
//! central allocate without bound, spin for minutes or hold its loop for seconds now get a clear
//! reply error, and central goes on answering — each case followed by a status query and, at the
//! end, a mission that still gets created and planned.

mod common;

use std::time::{Duration, Instant};

use common::{start_central, Scratch};
use mrmm_net::client::Client;
use mrmm_proto::{Key, MissionCreate, MissionView, SystemCmd, SystemStatus};
use serde_json::{json, Value};

/// A patrol create with parameters `params` and recipe `recipe`.
fn create(name: &str, recipe: &str, params: Value) -> MissionCreate {
    let params = params.as_object().map(|m| m.clone().into_iter().collect()).unwrap_or_default();
    MissionCreate { name: name.into(), recipe: recipe.into(), count: Some(2), params, ..Default::default() }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn central_refuses_hostile_requests_clearly_and_goes_on() -> anyhow::Result<()> {
    let dir = Scratch::new("bad-input");
    let (_central, ep) = start_central(&dir)?;
    let _robots = common::start_robots(&dir, &ep, 2)?;
    let client = Client::connect(std::slice::from_ref(&ep), Duration::from_secs(10)).await?;
    common::wait_robots(&client, 2).await?;
    let square = json!([[0, 0], [10, 0], [10, 10], [0, 10]]);
    let many: Vec<[f64; 2]> = (0..20_000).map(|i| [f64::from(i % 200), f64::from(i / 200) * 1.5]).collect();
    let ring: Vec<[f64; 2]> = (0..5_000)
        .map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 5000.0;
            [100.0 * a.cos(), 100.0 * a.sin()]
        })
        .collect();
    let deep = |n: usize| format!("<recipe name=\"x\" planner=\"patrol\">{}{}</recipe>", "<a>".repeat(n), "</a>".repeat(n));
    let cases: Vec<(&str, MissionCreate, &str)> = vec![
        ("a sync spacing of a nanometre", create("m1", "patrol", json!({"waypoints": square, "sync_spacing_max": 1e-9})), "sync_spacing_max"),
        ("20 000 waypoints", create("m2", "patrol", json!({"waypoints": many})), "at most 2000"),
        ("a recipe nested 30 000 deep", create("m3", &deep(30_000), json!({})), "deeper than 32"),
        (
            "a 300 KB recipe",
            create("m4", &format!("<recipe name=\"x\" planner=\"patrol\"><!-- {} --></recipe>", "x".repeat(300_000)), json!({})),
            "at most 262144",
        ),
        ("a region of 5 000 vertices", create("m5", "coverage", json!({"region": ring})), "at most 2000"),
        ("a trillion kicks", create("m6", "patrol", json!({"waypoints": square, "max_kicks": 1_000_000_000_000u64})), "max_kicks"),
        ("a million Lloyd iterations", create("m7", "coverage", json!({"region": square, "lloyd_iterations": 1_000_000})), "lloyd_iterations"),
        ("a thousand replicas", MissionCreate { replicas: Some(1000), ..create("m8", "patrol", json!({"waypoints": square})) }, "replicas"),
        (
            "more robots than the fleet",
            MissionCreate { count: Some(1_000_000), ..create("m9", "patrol", json!({"waypoints": square})) },
            "idle robots available",
        ),
    ];
    for (what, c, expect) in cases {
        let t = Instant::now();
        let r = client.query::<Value>(Key::SystemCmd(SystemCmd::Create), Some(&c)).await;
        let e = r.expect_err(what).to_string();
        println!("{what}: refused in {:?}: {}", t.elapsed(), e.chars().take(160).collect::<String>());
        assert!(e.contains(expect), "{what}: expected {expect:?} in {e}");
        let _: SystemStatus = client.query(Key::SystemStatus, None::<&()>).await?;
    }
    // Malformed requests and a message over the size limit (dropped by the transport).
    let raw = |body: Vec<u8>| async {
        mrmm_net::net::query::<Value>(client.session(), &Key::SystemCmd(SystemCmd::Create).to_string(), Some(body), Duration::from_secs(3)).await
    };
    let e = raw(b"{\"name\": ".to_vec()).await.expect_err("truncated JSON").to_string();
    assert!(e.contains("mission create request"), "{e}");
    let e = raw(br#"{"name": "x", "recipe": "patrol", "evil": 1}"#.to_vec()).await.expect_err("unknown field").to_string();
    assert!(e.contains("unknown field"), "{e}");
    let huge = format!("{{\"name\": \"big\", \"recipe\": \"{}\"}}", "x".repeat(2 << 20));
    assert!(raw(huge.into_bytes()).await.is_err(), "a 2 MiB request got an answer");
    let _: SystemStatus = client.query(Key::SystemStatus, None::<&()>).await?;

    // And central still does its work.
    let ok: MissionView = client.query(Key::SystemCmd(SystemCmd::Create), Some(&create("good", "patrol", json!({"waypoints": square})))).await?;
    assert_eq!(ok.robots.len(), 2);
    client.close().await;
    Ok(())
}
