//! Seeded simulation: `mrmm_sim::Config::barriers` (see its documentation for the world and the
//! faults), with every invariant of `mrmm_sim` checked after every event.
//!
//! `cargo test -p mrmm-sim --test barrier_sim` runs 1 000 seeds; `MRMM_SIM_SEEDS=N` more;
//! `MRMM_SIM_SEED=S … -- --nocapture` replays one seed with its trace.

mod common;

#[test]
fn invariants_hold_for_every_seed() {
    common::seeds("barrier", 1000, mrmm_sim::Config::barriers);
}

/// Nested teams: a barrier never releases before every live member of its scope arrived (the
/// mission's barrier: every robot; a team's: that team's), checked after every event.
#[test]
fn invariants_hold_for_every_seed_with_teams() {
    common::seeds("team barrier", 500, mrmm_sim::Config::team_barriers);
}
