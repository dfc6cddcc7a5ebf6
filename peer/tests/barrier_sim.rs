//! Seeded message-level simulation of a team's decentralised barriers (issue 5, invariant 4):
//! members arrive at barriers after random work, publish their arrival once (lost or delayed at
//! random) and re-publish while they wait; a member that hears an arrival it is already past
//! publishes its own again (the executor's echo); some members crash, and the others learn it from
//! liveliness after a random lag. Invariant: no member ever leaves a barrier before every member
//! that is alive has arrived there. Liveness: every surviving member gets through every barrier.
//!
//! `cargo test -p mrmm-peer --test barrier_sim` runs 1 000 seeds; `MRMM_SIM_SEEDS=N` more;
//! `MRMM_SIM_SEED=S` replays one.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use mrmm_peer::barrier::Barrier;
use mrmm_peer::proto::SyncArrival;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const POINTS: u32 = 3;
const ROUNDS: u32 = 6;
const REPUBLISH: f64 = 0.5;

#[derive(Debug)]
enum Ev {
    /// Member `i` finished its work and arrives at its next barrier.
    Arrive(usize),
    Deliver { to: usize, a: SyncArrival },
    Gone { at: usize, who: usize },
    Crash(usize),
    Republish(usize),
}

struct Member {
    barrier: Barrier,
    /// Index of the barrier it is at or working towards.
    next: u32,
    waiting: bool,
    crashed: bool,
    /// Truth: how many barriers it has arrived at.
    arrived: u32,
    echo_due: bool,
    last_echo: f64,
}

/// Barrier `i` in order: (round, point).
fn at(i: u32) -> (u32, u32) {
    (i / POINTS, i % POINTS)
}

struct Queue {
    heap: BinaryHeap<(Reverse<u64>, Reverse<u64>, usize)>,
    evs: Vec<Option<Ev>>,
}

impl Queue {
    fn push(&mut self, t: f64, e: Ev) {
        self.evs.push(Some(e));
        let n = self.evs.len();
        self.heap.push((Reverse((t * 1e9) as u64), Reverse(n as u64), n - 1));
    }
    fn pop(&mut self) -> Option<(f64, Ev)> {
        let (Reverse(t), _, k) = self.heap.pop()?;
        Some((t as f64 / 1e9, self.evs[k].take()?))
    }
}

fn run(seed: u64) -> Result<(), String> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rng.gen_range(2..=8);
    let loss = [0.0, 0.1, 0.4][rng.gen_range(0..3)];
    let max_delay = [0.002, 0.05, 0.3][rng.gen_range(0..3)];
    let crashes = rng.gen_range(0..n.min(3));
    let names: Vec<String> = (0..n).map(|i| format!("m{i}")).collect();
    let mut members: Vec<Member> = (0..n)
        .map(|i| Member { barrier: Barrier::new(&names[i], 7, &names), next: 0, waiting: false, crashed: false, arrived: 0, echo_due: false, last_echo: -1.0 })
        .collect();
    let mut q = Queue { heap: BinaryHeap::new(), evs: Vec::new() };
    for i in 0..n {
        q.push(rng.gen_range(0.0..1.0), Ev::Arrive(i));
    }
    for _ in 0..crashes {
        q.push(rng.gen_range(0.0..8.0), Ev::Crash(rng.gen_range(0..n)));
    }
    let total = POINTS * ROUNDS;
    let mut now = 0.0;
    while let Some((t, ev)) = q.pop() {
        now = t;
        if now > 300.0 {
            break;
        }
        let mut publish: Option<usize> = None;
        let mut echo: Option<(usize, u32, u32)> = None;
        match ev {
            Ev::Arrive(i) if !members[i].crashed && members[i].next < total => {
                let m = &mut members[i];
                m.arrived = m.next + 1;
                m.waiting = true;
                let (round, point) = at(m.next);
                m.barrier.arrival(&SyncArrival { robot: names[i].clone(), epoch: 7, point, round });
                publish = Some(i);
                q.push(now + REPUBLISH, Ev::Republish(i));
            }
            Ev::Republish(i) if !members[i].crashed && members[i].waiting => {
                publish = Some(i);
                q.push(now + REPUBLISH, Ev::Republish(i));
            }
            Ev::Deliver { to, a } if !members[to].crashed => {
                let m = &mut members[to];
                // As `Executor::heard`: an arrival at or before ours, where we do not wait, is echoed.
                let waiting_there = m.waiting && at(m.next) == (a.round, a.point);
                if m.barrier.arrival(&a) && m.barrier.at_or_behind_us(&a) && !waiting_there {
                    m.echo_due = true;
                }
                if m.echo_due && now - m.last_echo >= REPUBLISH {
                    m.echo_due = false;
                    m.last_echo = now;
                    echo = m.barrier.mine().map(|(round, point)| (to, round, point));
                }
            }
            Ev::Gone { at, who } if !members[at].crashed => members[at].barrier.member_gone(&names[who]),
            Ev::Crash(i) if !members[i].crashed => {
                members[i].crashed = true;
                for j in (0..n).filter(|j| *j != i) {
                    q.push(now + rng.gen_range(0.001..1.0), Ev::Gone { at: j, who: i });
                }
            }
            _ => {}
        }
        let publish = publish.map(|i| (i, at(members[i].next))).or(echo.map(|(i, r, p)| (i, (r, p))));
        if let Some((i, (round, point))) = publish {
            for j in (0..n).filter(|j| *j != i) {
                if !rng.gen_bool(loss) {
                    let a = SyncArrival { robot: names[i].clone(), epoch: 7, point, round };
                    q.push(now + rng.gen_range(0.0..=max_delay), Ev::Deliver { to: j, a });
                }
            }
        }
        // Whoever can leave its barrier does: the invariant is checked first.
        for i in 0..n {
            let m = &members[i];
            if m.crashed || !m.waiting {
                continue;
            }
            let (round, point) = at(m.next);
            if !m.barrier.released(point, round) {
                continue;
            }
            if let Some(j) = members.iter().position(|o| !o.crashed && o.arrived < m.next + 1) {
                return Err(format!("seed {seed} t={now:.3}: m{i} left barrier {:?} before m{j} (alive) arrived there", at(m.next)));
            }
            let m = &mut members[i];
            m.waiting = false;
            m.next += 1;
            if m.next < total {
                q.push(now + rng.gen_range(0.05..1.0), Ev::Arrive(i));
            }
        }
    }
    match members.iter().position(|m| !m.crashed && m.next < total) {
        Some(i) => Err(format!("seed {seed}: m{i} stuck at barrier {:?} (t={now:.1})", at(members[i].next))),
        None => Ok(()),
    }
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

#[test]
fn barriers_never_release_early_and_never_deadlock() {
    if let Some(seed) = env_u64("MRMM_SIM_SEED") {
        run(seed).unwrap_or_else(|e| panic!("{e}"));
        return;
    }
    let seeds = env_u64("MRMM_SIM_SEEDS").unwrap_or(1000);
    for seed in 0..seeds {
        if let Err(e) = run(seed) {
            panic!("{e}; replay with MRMM_SIM_SEED={seed}");
        }
    }
}
