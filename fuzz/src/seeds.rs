//! Writes the fuzz targets' starting corpora (`fuzz/seeds/<target>/`) from real messages of the
//! production machines, and the seal target's test PKI (`fuzz/fixture/`), so that the fuzzer starts
//! from inputs that get past the decoders. Run: `cargo run --manifest-path fuzz/Cargo.toml --bin seeds`.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

use std::fs;
use std::path::{Path, PathBuf};

use mrmm_core::robot::Event as RobotEvent;
use mrmm_fuzz::{fixture_dir, robot, started_view, telemetry, Host};
use mrmm_net::security::{pki, seal::Sealer, Identity};
use mrmm_proto::security::{Role, SecuritySection};
use mrmm_proto::{MissionCtl, RobotCommand, SyncArrival, Time};

fn json<T: serde::Serialize>(v: &T) -> Vec<u8> {
    match mrmm_proto::to_json(v) {
        Ok(b) => b,
        Err(e) => panic!("encode: {e}"),
    }
}

/// One input: frames (selector, payload) joined by zero bytes.
fn input(frames: &[(u8, Vec<u8>)]) -> Vec<u8> {
    let mut out = Vec::new();
    for (i, (sel, payload)) in frames.iter().enumerate() {
        if i > 0 {
            out.push(0);
        }
        out.push(*sel);
        out.extend(payload);
    }
    out
}

fn write(dir: &Path, target: &str, name: &str, bytes: &[u8]) {
    let d = dir.join(target);
    if let Err(e) = fs::create_dir_all(&d).and_then(|_| fs::write(d.join(name), bytes)) {
        panic!("write {target}/{name}: {e}");
    }
}

fn main() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let corpus = root.join("seeds");
    recipes(&root, &corpus);
    let telemetry = messages(&corpus);
    let dir = seals(&corpus, &telemetry);
    println!("corpora in {}, fixture in {}", corpus.display(), dir.display());
}

/// recipe: every recipe of the bank.
fn recipes(root: &Path, corpus: &Path) {
    for entry in fs::read_dir(root.join("../recipes")).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "xml") {
            if let Ok(text) = fs::read(&path) {
                let name = path.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
                write(corpus, "recipe", &name, &text);
            }
        }
    }
}

/// central, host and robot: real messages of a running patrol. Returns a robot's telemetry.
fn messages(corpus: &Path) -> Vec<u8> {
    let mut head = Host::new("central");
    head.start_patrol(2);
    // A head without replicas commits at once: its plans go out.
    let mut solo = Host::new("central");
    solo.start_patrol(0);
    for i in 1..=20 {
        head.now = Time::from_secs(f64::from(i) * 0.1);
        head.feed(mrmm_core::mission::host::Event::Tick);
    }
    let mut r1 = robot("r1");
    let t = telemetry(&mut r1, Time::ZERO).map(|t| json(&t)).unwrap_or_default();
    let start = mrmm_proto::MissionStart {
        spec: mrmm_proto::MissionSpecWire {
            name: "q".into(),
            recipe_name: "patrol".into(),
            recipe_xml: mrmm_planner::recipe::bank("patrol").unwrap_or_default().into(),
            planner: "patrol".into(),
            params: [("waypoints".to_string(), "[[0,0],[5,0],[5,5]]".to_string())].into(),
            replicas: 1,
            map: None,
            paused: false,
        },
        members: vec![mrmm_fuzz::member("r3", 2.0)],
        anew: false,
        lineage: 0,
    };
    let view = json(&started_view("central", &start));
    let joined = json(&MissionCtl::Joined { member: mrmm_fuzz::member("r3", 3.0) });

    // central: operator requests on each key, telemetry, a status report, time.
    let create = br#"{"name": "c", "recipe": "coverage", "count": 1, "params": {"region": [[0,0],[10,0],[10,10],[0,10]], "samples": 50}}"#.to_vec();
    let mv = br#"{"robot": "r3", "to": "p"}"#.to_vec();
    let term = br#"{"name": "p"}"#.to_vec();
    let goto = br#"{"robot": "r3", "x": 3.0, "y": 4.0}"#.to_vec();
    write(corpus, "central", "commands", &input(&[(7, create.clone()), (15, vec![]), (6, mv), (0, vec![]), (3, vec![]), (8, term), (5, goto), (15, vec![])]));
    write(
        corpus,
        "central",
        "reports",
        &input(&[(9, t.clone()), (10, view.clone()), (26, view.clone()), (11, b"r1".to_vec()), (31, vec![]), (12, b"r1".to_vec()), (4, b"p".to_vec())]),
    );

    // host: the head's own chain messages from each node, a start, a join, telemetry, a plan.
    let mut frames = Vec::new();
    for (i, env) in head.sent.iter().enumerate() {
        let sel = [0u8, 16, 32, 48][i % 4];
        frames.push((sel, json(env)));
        frames.push((15, vec![]));
    }
    write(corpus, "host", "chain", &input(&frames));
    let plan = solo.plans.first().map(json).unwrap_or_default();
    write(
        corpus,
        "host",
        "control",
        &input(&[(4, json(&start)), (5, joined), (7, t.clone()), (8, view), (9, plan), (14, vec![]), (15, vec![]), (13, b"p".to_vec())]),
    );

    // robot: plans as its head sends them, admissions, leaves, orders, arrivals, time.
    let mut frames = Vec::new();
    for a in solo.assignments.iter().take(2) {
        frames.push((0, json(&RobotCommand::Plan(Box::new(a.clone())))));
        frames.push((7, vec![]));
    }
    frames.push((0, json(&RobotCommand::Admit { mission: "p".into(), managers: vec!["central".into()], members: vec!["r1".into(), "r2".into()] })));
    frames.push((3, json(&SyncArrival { robot: "r2".into(), epoch: 1, point: 0, round: 0 })));
    frames.push((6, vec![]));
    frames.push((0, json(&RobotCommand::Leave { mission: "p".into(), epoch: 1 })));
    frames.push((7, vec![]));
    write(corpus, "robot", "plans", &input(&frames));
    let _ = r1.handle(Time::from_secs(1.0), RobotEvent::Tick);
    t
}

/// seal: a fixture fleet, and a robot's sealed telemetry `t`. Returns where the fixture is.
fn seals(corpus: &Path, t: &[u8]) -> PathBuf {
    let dir = fixture_dir();
    if !dir.join("ca.crt").exists() {
        if let Err(e) = fs::create_dir_all(&dir).map_err(|e| e.to_string()).and_then(|_| pki::init(&dir).map_err(|e| e.to_string())) {
            panic!("fixture CA: {e}");
        }
        if let Err(e) = pki::issue(&dir, Role::Robot, "r1", &[], 3650) {
            panic!("fixture certificate: {e}");
        }
    }
    let now_ms = match fs::read_to_string(dir.join("now_ms")) {
        Ok(s) => s.trim().parse().unwrap_or(0),
        Err(_) => {
            let now = u64::try_from(mrmm_net::security::unix_now_s()).unwrap_or(0) * 1000;
            let _ = fs::write(dir.join("now_ms"), now.to_string());
            now
        }
    };
    let identity = match Identity::load("security", &SecuritySection::from_dir(&dir, "r1")) {
        Ok(i) => i,
        Err(e) => panic!("fixture identity: {e}"),
    };
    // A seal tagged for r1 itself too (the seal target's verifier is r1's): the tag path.
    let ca = mrmm_net::security::seal::parse_ca(&identity.ca_der).unwrap_or_else(|e| panic!("fixture CA: {e}"));
    let public = match mrmm_net::security::seal::check_cert(&ca, &identity.cert_der, mrmm_net::security::unix_now_s()) {
        Ok(p) => p.public_key,
        Err(e) => panic!("fixture r1.crt: {e}"),
    };
    let me = mrmm_net::security::pair::Pairs::new(identity.pair_secret());
    let tags: Vec<_> = me.key(&public).map(|k| vec![(mrmm_net::security::pair::key_id(&public), k)]).unwrap_or_default();
    let sealer = Sealer::secure(identity);
    let key = mrmm_proto::Key::RobotTelemetry("r1".into()).to_string();
    for (name, att) in [
        ("telemetry", sealer.seal(&key, t, now_ms)),
        ("telemetry-tagged", sealer.seal_for(&key, t, now_ms, &tags, false, false)),
        ("telemetry-by-id", sealer.seal_for(&key, t, now_ms, &tags, false, true)),
    ] {
        let mut sealed = u16::try_from(att.len()).unwrap_or(u16::MAX).to_le_bytes().to_vec();
        sealed.extend(&att);
        sealed.extend(t);
        write(corpus, "seal", name, &sealed);
    }
    dir
}
