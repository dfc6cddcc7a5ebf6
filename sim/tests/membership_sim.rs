//! Seeded simulation: `mrmm_sim::Config::membership` (see its documentation for the world and the
//! faults), with every invariant of `mrmm_sim` checked after every event.
//!
//! `cargo test -p mrmm-sim --test membership_sim` runs 400 seeds (one of the two
//! slowest simulations: 1 000 took 87 s of CI's 2 cores); `MRMM_SIM_SEEDS=N` more;
//! `MRMM_SIM_SEED=S … -- --nocapture` replays one seed with its trace.

mod common;

#[test]
fn invariants_hold_for_every_seed() {
    common::seeds("membership", 400, mrmm_sim::Config::membership);
}
