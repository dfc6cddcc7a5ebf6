//! What one event costs central's system manager as the fleet grows: the machine alone (no
//! network), N robots registered, two missions of N/2 adopted from their heads' reports. Printed
//! per kind of event, in µs, for N = 100 … 3 000: a cost that grows with N per event is what
//! would take central's loop down at scale (issue 35). Telemetry is the hot path (every robot,
//! 5 a second by default: 5 000 events a second at 1 000 robots); the tick comes 4 times a second
//! whatever N, so its cost is what it takes of central's loop when nothing happens.
//!
//! `cargo bench -p mrmm-core --bench central_loop`

use std::time::Instant;

use mrmm_core::central::system::{Event, Req, Request, SystemManager, ADOPT_S};
use mrmm_proto::{Behaviour, MissionView, Pose, RobotInfo, Role, Sender, Telemetry, Time};

/// A system manager with `n` robots registered and two missions of n/2 run by host `h1`.
fn fleet(n: usize) -> (SystemManager, Vec<String>) {
    let mut sm = SystemManager::new("central".into(), Time::from_secs(-ADOPT_S));
    sm.handle(Time::ZERO, Event::HostAlive { node: "central".into() });
    sm.handle(Time::ZERO, Event::HostAlive { node: "h1".into() });
    let ids: Vec<String> = (1..=n).map(|i| format!("r{i}")).collect();
    for (i, id) in ids.iter().enumerate() {
        sm.handle(Time::ZERO, Event::RobotAlive { id: id.into() });
        sm.handle(Time::ZERO, Event::RobotRegistered(RobotInfo { capabilities: vec!["camera".into()], ..RobotInfo::new(id, "ground", 1.0) }));
        sm.handle(Time::ZERO, Event::Telemetry(Box::new(running(id, 1, mission_of(i, n)))));
    }
    for (name, members) in [("a", &ids[..n / 2]), ("b", &ids[n / 2..])] {
        let members: Vec<&str> = members.iter().map(String::as_str).collect();
        sm.handle(Time::from_secs(0.5), report(name, &members));
    }
    (sm, ids)
}

fn mission_of(i: usize, n: usize) -> &'static str {
    if i < n / 2 {
        "a"
    } else {
        "b"
    }
}

fn running(id: &str, seq: u64, mission: &str) -> Telemetry {
    Telemetry { seq, mission: Some(mission.into()), behaviour: Behaviour::Hold, pose: Pose::default(), ..Telemetry::resting(id, seq as f64) }
}

fn report(name: &str, robots: &[&str]) -> Event {
    Event::MissionStatus { view: Box::new(MissionView::running(name, "patrol", "h1", 1, robots)), from: Sender::new(Role::Host, "h1") }
}

/// Mean µs of `f` over `reps` calls.
fn time(reps: usize, mut f: impl FnMut(usize)) -> f64 {
    let t0 = Instant::now();
    for k in 0..reps {
        f(k);
    }
    t0.elapsed().as_secs_f64() * 1e6 / reps as f64
}

fn main() {
    println!("| N | telemetry µs/event | tick µs | mission report (N/2 robots) µs | robot lost + back µs | fleet table query µs |");
    println!("|---:|---:|---:|---:|---:|---:|");
    for n in [100, 300, 1000, 3000] {
        let (mut sm, ids) = fleet(n);
        let mut now = Time::from_secs(1.0);
        let mut seq = 2;
        let telemetry = time(200_000, |k| {
            let i = k % n;
            if i == 0 {
                seq += 1;
                now += 0.2;
            }
            sm.handle(now, Event::Telemetry(Box::new(running(&ids[i], seq, mission_of(i, n)))));
        });
        // Central ticks 4 times a second (controls and starts due, info asked again, recovery,
        // the agent's look once a second): every robot answered, nothing due.
        let tick = time(20_000, |_| {
            now += 0.25;
            sm.handle(now, Event::Tick);
        });
        let half: Vec<&str> = ids[..n / 2].iter().map(String::as_str).collect();
        let reports = time(2_000, |_| {
            now += 0.001;
            sm.handle(now, report("a", &half));
        });
        let churn = time(2_000, |k| {
            let id = &ids[(k * 7919) % n];
            now += 0.001;
            sm.handle(now, Event::RobotGone { id: id.into() });
            sm.handle(now, Event::RobotAlive { id: id.into() });
        });
        let table = time(200, |k| {
            sm.handle(now, Event::Operator { req: Req::Query(k as u64), request: Request::Robots });
        });
        println!("| {n} | {telemetry:.2} | {tick:.1} | {reports:.1} | {churn:.2} | {table:.0} |");
    }
}
