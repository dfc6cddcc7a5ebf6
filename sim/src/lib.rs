//! Seeded simulations of mrmm that drive the production state machines — [`CentralCore`]
//! (system manager and agent), [`HostCore`] (with the real mission managers and chain
//! replicas) and [`Robot`] (with its real executor, barrier and simulated body) — over a
//! simulated network: message delay and loss, partitions, crashes with memory loss, liveliness
//! seen a lease late, and false suspicion (liveliness lost for a node that is alive). The
//! simulation plays only what the drivers do (deliver publications, route queries, declare
//! tokens); every decision is the machines'. After every event it checks the invariants
//! (`invariants.rs`); a run returns the first violation with the seed that replays it.
//!
//! Two smaller simulations of one machine each live here too: chain replication alone
//! ([`chain`]: the production `Registry` over a lossy network) and traffic on a floor plan
//! ([`traffic`]: the production `Traffic` with robots driving its grants, and the lifelong-PIBT
//! reference [`traffic::pibt`]).
//!
//! [`CentralCore`]: mrmm_core::central::CentralCore
//! [`HostCore`]: mrmm_core::mission::host::HostCore
//! [`Robot`]: mrmm_core::robot::Robot
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod chain;
mod invariants;
mod net;
mod ops;
pub mod traffic;
mod world;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use world::World;

/// What the operator does during a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ops {
    /// No managers: every robot is handed the same plan of `points` barriers per round for
    /// `rounds` rounds, with random work between barriers.
    /// `mode`: how the team runs them. `teams` > 1: the robots are split into that many leaf
    /// teams of one mission, each round's barriers are each team's own, and every plan starts
    /// with a mission-wide barrier.
    Barriers { points: u32, rounds: u32, mode: mrmm_proto::BarrierMode, teams: u32 },
    /// One mission started on the first mission host, then random joins and leaves sent to its
    /// head (re-sent until acknowledged, as the system manager does).
    OneMission,
    /// Random operator commands through central: creates, moves, frees, terminations.
    Random,
}

/// The simulated world and how hostile it is.
#[derive(Debug, Clone, Copy)]
pub struct Config {
    pub seed: u64,
    /// A central node: system manager, agent (autonomy `act`), mission host `central`, planner.
    pub central: bool,
    pub robots: usize,
    /// Extra mission-host nodes (`h1`, …).
    pub hosts: usize,
    pub ops: Ops,
    /// Seconds with faults, then `quiet` seconds healed (operator commands stop too).
    pub duration: f64,
    pub quiet: f64,
    /// Probability that a message or query is lost.
    pub loss: f64,
    /// Message delay, uniform in `[0, max_delay]` seconds.
    pub max_delay: f64,
    /// Mean seconds between two crashes (one node down at a time), 0 for none.
    pub crash_every: f64,
    /// Whether central may crash.
    pub crash_central: bool,
    /// Whether a crashed node restarts (with its memory lost).
    pub restart: bool,
    /// Mean seconds between two partitions, 0 for none.
    pub partition_every: f64,
    /// Mean seconds between two false suspicions, 0 for none.
    pub suspect_every: f64,
    /// Liveliness loss through a partition or a suspicion is seen this late.
    pub lease: f64,
    /// Robots and mission hosts keep their chain state on disk (`state_dir`): a restart brings
    /// their replicas back as they were. Central's host always does (beside its journal).
    pub disks: bool,
    /// During a partition, now and then every node on central's side loses power at once and
    /// comes back (central first): a mission whose chain lives on the other side is started
    /// anew by central — a new lineage beside the old one until the partition heals. Drawn from
    /// a random stream of its own, so seeds without such a power cycle run as before.
    pub side_cycles: bool,
    /// Probability that central's system manager misses a liveliness change (its inbox dropped
    /// it, or a router withdrew a token another link still holds): only its roll call
    /// (`roll_call.rs` in the core) can correct it. Drawn from a random stream of its own.
    pub missed_live: f64,
}

impl Config {
    /// The chain simulation: mission hosts and robots, no central; one mission under steady
    /// control traffic; crashes, loss, delay, partitions.
    pub fn chain(seed: u64) -> Config {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x1);
        Config {
            seed,
            central: false,
            robots: r.gen_range(2..=5),
            hosts: 1,
            ops: Ops::OneMission,
            duration: 30.0,
            quiet: 25.0,
            loss: [0.0, 0.01, 0.05, 0.2][r.gen_range(0..4)],
            max_delay: [0.002, 0.02, 0.2][r.gen_range(0..3)],
            crash_every: [0.0, 4.0, 8.0][r.gen_range(0..3)],
            crash_central: false,
            restart: true,
            partition_every: [0.0, 5.0, 10.0][r.gen_range(0..3)],
            suspect_every: 0.0,
            lease: 1.0,
            disks: r.gen_bool(0.5),
            side_cycles: false,
            missed_live: 0.0,
        }
    }

    /// The barrier simulation: robots with one plan, no managers; loss, delay, crashes for good.
    pub fn barriers(seed: u64) -> Config {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x2);
        Config {
            seed,
            central: false,
            robots: r.gen_range(2..=7),
            hosts: 0,
            // Odd seeds run the paper's leader barrier, even ones the mesh barrier.
            ops: Ops::Barriers {
                points: 3,
                rounds: 4,
                mode: if seed % 2 == 1 { mrmm_proto::BarrierMode::Leader } else { mrmm_proto::BarrierMode::Mesh },
                teams: 1,
            },
            duration: 40.0,
            quiet: 80.0,
            loss: [0.0, 0.1, 0.4][r.gen_range(0..3)],
            max_delay: [0.002, 0.05, 0.3][r.gen_range(0..3)],
            crash_every: [0.0, 6.0, 12.0][r.gen_range(0..3)],
            crash_central: false,
            restart: false,
            partition_every: 0.0,
            suspect_every: 0.0,
            lease: 1.0,
            disks: false,
            side_cycles: false,
            missed_live: 0.0,
        }
    }

    /// The barrier simulation with a team tree: the robots of [`Config::barriers`] split into two
    /// or three leaf teams of one mission, a mission-wide barrier first, then each team's own.
    pub fn team_barriers(seed: u64) -> Config {
        let mut cfg = Config::barriers(seed);
        if let Ops::Barriers { teams, .. } = &mut cfg.ops {
            *teams = 2 + (seed / 2 % 2) as u32;
        }
        cfg.robots = cfg.robots.max(3);
        cfg
    }

    /// The membership simulation: central and robots (each a mission host), random operator
    /// commands; robots crash and return, liveliness is falsely lost at times.
    pub fn membership(seed: u64) -> Config {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x3);
        Config {
            seed,
            central: true,
            robots: r.gen_range(2..=6),
            hosts: 0,
            ops: Ops::Random,
            duration: 40.0,
            quiet: 25.0,
            loss: 0.0,
            max_delay: [0.002, 0.02, 0.1][r.gen_range(0..3)],
            crash_every: [0.0, 5.0, 10.0][r.gen_range(0..3)],
            crash_central: false,
            restart: true,
            partition_every: 0.0,
            suspect_every: [0.0, 6.0][r.gen_range(0..2)],
            lease: 1.0,
            disks: false,
            side_cycles: false,
            missed_live: [0.0, 0.2][r.gen_range(0..2)],
        }
    }

    /// The whole system: central, a mission host, robots; every fault.
    pub fn system(seed: u64) -> Config {
        let mut r = ChaCha8Rng::seed_from_u64(seed ^ 0x4);
        Config {
            seed,
            central: true,
            robots: r.gen_range(3..=6),
            hosts: r.gen_range(0..=1),
            ops: Ops::Random,
            duration: 40.0,
            quiet: 30.0,
            loss: [0.0, 0.01, 0.05][r.gen_range(0..3)],
            max_delay: [0.002, 0.02, 0.1][r.gen_range(0..3)],
            crash_every: [0.0, 5.0, 10.0][r.gen_range(0..3)],
            crash_central: true,
            restart: true,
            partition_every: [0.0, 8.0, 15.0][r.gen_range(0..3)],
            suspect_every: [0.0, 8.0][r.gen_range(0..2)],
            lease: 1.0,
            disks: r.gen_bool(0.5),
            side_cycles: true,
            missed_live: [0.0, 0.2][r.gen_range(0..2)],
        }
    }
}

/// What a run did.
#[derive(Debug, Clone, Default)]
pub struct Report {
    pub seed: u64,
    pub events: u64,
    /// Messages delivered (after the network's losses).
    pub messages: u64,
    /// Publications and questions sent (lost or not).
    pub sent: u64,
    pub crashes: u32,
    pub partitions: u32,
    pub suspicions: u32,
    /// Heads elected (a node starting to lead a mission).
    pub leads: u32,
    /// Control queries acknowledged by a head.
    pub acked: u32,
    /// Operator commands answered ok.
    pub commands_ok: u32,
    /// Barriers passed by robots.
    pub barriers: u32,
    /// Missions running at the end.
    pub missions_at_end: usize,
    /// Of those, paused ones (whose live members were checked to hold).
    pub paused_at_end: u32,
    /// Missions whose chain lost a majority of its memory (several restarts): they cannot get a
    /// head again until memory is durable, so the end checks pass over them.
    pub unrecoverable: u32,
    /// Missions central started anew from its journal (a new lineage), and of those, how many
    /// without every member back.
    pub anew: u32,
    pub anew_short: u32,
    /// Heads of a replaced lineage fenced by central.
    pub fenced: u32,
    /// Missions central defines (created ok, not terminated) that nobody leads at the end
    /// (counted without disks; with disks such a mission fails the run).
    pub headless: u32,
    /// Live members of missions that require capabilities, checked at the end to have them.
    pub required_checked: u32,
    /// Forged messages (another robot's arrival or release, an unsealed arrival) robots refused.
    pub forged_refused: u32,
    /// The trace, when asked for.
    pub trace: Vec<String>,
}

/// A run's first violated invariant.
#[derive(Debug, Clone)]
pub struct Violation {
    pub seed: u64,
    pub at: f64,
    pub what: String,
    pub trace: Vec<String>,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "seed {} at t={:.3}: {}", self.seed, self.at, self.what)
    }
}

/// Runs one simulation; `trace` keeps a readable log of it.
pub fn run(cfg: Config, trace: bool) -> Result<Report, Violation> {
    World::new(cfg, trace).run()
}

/// Runs `seeds` seeds from `first` with `config`, on every core; the first violation (by seed)
/// is returned (a machine that panics is a violation too).
pub fn run_many(first: u64, seeds: u64, config: fn(u64) -> Config) -> Result<Vec<Report>, Violation> {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()).min(8) as u64;
    let results: Vec<Result<Vec<Report>, Violation>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    let mut out = Vec::new();
                    let mut seed = first + t;
                    while seed < first + seeds {
                        let r = std::panic::catch_unwind(|| run(config(seed), false));
                        match r {
                            Ok(r) => out.push(r?),
                            Err(e) => {
                                let what = e.downcast_ref::<String>().cloned().or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()));
                                return Err(Violation { seed, at: f64::NAN, what: format!("a machine panicked: {}", what.unwrap_or_default()), trace: vec![] });
                            }
                        }
                        seed += threads;
                    }
                    Ok(out)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|_| Err(Violation { seed: first, at: 0.0, what: "a simulation thread panicked".into(), trace: vec![] })))
            .collect()
    });
    let mut reports = Vec::new();
    let mut first_bad: Option<Violation> = None;
    for r in results {
        match r {
            Ok(rs) => reports.extend(rs),
            Err(v) if first_bad.as_ref().is_none_or(|b| v.seed < b.seed) => first_bad = Some(v),
            Err(_) => {}
        }
    }
    match first_bad {
        Some(v) => Err(v),
        None => Ok(reports),
    }
}
