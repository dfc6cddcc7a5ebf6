//! The seeded message-level simulation of chain-replicated mission managers (issue 5): random
//! crashes and restarts, message loss, delay and duplication, partitions. Every seed must keep
//! the invariants (see `mrmm_sim::chain::Invariants`).
//!
//! `cargo test -p mrmm-sim --test replica_sim` runs 1 000 seeds. More:
//! `MRMM_SIM_SEEDS=100000 cargo test --release -p mrmm-sim --test replica_sim -- --nocapture`.
//! Replay one seed with its trace: `MRMM_SIM_SEED=1234 cargo test -p mrmm-sim --test replica_sim -- --nocapture`.

use mrmm_core::mission::chain::Params;
use mrmm_sim::chain::{Sim, World};

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

#[test]
fn invariants_hold_for_every_seed() {
    if let Some(seed) = env_u64("MRMM_SIM_SEED") {
        let w = World::for_seed(seed);
        println!("seed {seed}: {w:?}");
        match Sim::new(seed, w, Params::default()).with_trace().run() {
            Ok(r) => {
                for line in &r.trace {
                    println!("{line}");
                }
                println!("ok: {} heads elected, {} commits, {} heads at the end", r.leads, r.commits, r.heads_at_end);
            }
            Err((e, trace)) => {
                for line in trace {
                    println!("{line}");
                }
                panic!("{e}");
            }
        }
        return;
    }
    let seeds = env_u64("MRMM_SIM_SEEDS").unwrap_or(1000);
    let first = env_u64("MRMM_SIM_FIRST").unwrap_or(0);
    let (mut leads, mut commits, mut crashes, mut partitions, mut headless, mut unrecoverable) = (0, 0, 0, 0, 0, 0);
    for seed in first..first + seeds {
        let w = World::for_seed(seed);
        match Sim::new(seed, w, Params::default()).run() {
            Ok(r) => {
                leads += r.leads;
                commits += r.commits;
                crashes += r.crashes;
                partitions += r.partitions;
                if r.heads_at_end == 0 {
                    if headless < 5 {
                        println!("seed {seed} ended headless (recoverable: {})", r.recoverable);
                    }
                    headless += 1;
                    if !r.recoverable {
                        unrecoverable += 1;
                    }
                }
                // Liveness: with a majority of the chain holding its memory (always, with disks,
                // power cycles included), healing leaves exactly one head.
                assert!(
                    r.heads_at_end == 1 || (!r.recoverable && !r.durable),
                    "seed {seed}: {} heads after healing though the chain kept its memory; replay with MRMM_SIM_SEED={seed}",
                    r.heads_at_end
                );
            }
            Err((e, _)) => panic!("{e}; replay with MRMM_SIM_SEED={seed}"),
        }
    }
    println!(
        "{seeds} seeds: {leads} heads elected, {commits} commits, {crashes} crashes, {partitions} partitions; \
         {headless} ended headless ({unrecoverable} because a majority of the chain lost its memory)"
    );
}
