//! The energy experiment on a short day: what each policy does to the patrol.

use super::*;

fn office() -> (NavGraph, Recipe) {
    let (name, text) = mrmm_maps::data::OPEN_RMF[0];
    (mrmm_maps::rmf::parse(name, text).expect("graph"), recipe::parse(recipe::bank("patrol").expect("shipped")).expect("recipe"))
}

/// An hour on batteries that last 20 minutes (charged in 5): every policy's run.
fn short_day(policy: Policy) -> Row {
    let (g, r) = office();
    let day = Day { length_s: 3600.0, life_s: 1200.0, charge_s: 300.0, ..Day::default() };
    one(&day, &g, &r, policy).expect("run").0
}

/// mrmm's policy keeps the patrol whole all day with its two spares: no robot runs dry or falls
/// below 5 %, the patrol never has fewer than its six, every robot charges.
#[test]
fn the_policy_keeps_the_patrol_whole() {
    let r = short_day(Policy::Mrmm);
    assert_eq!((r.died, r.under_5), (0, 0), "{r:?}");
    assert_eq!(r.short_s, 0.0, "the patrol kept its six: {r:?}");
    assert!(r.errands >= 8 && r.charging_s > 0.0, "every robot charged at least once: {r:?}");
}

/// Without charging every robot runs dry and the patrol stops; charging without spares keeps
/// the robots alive but the patrol short of its six for much of the day — the spares are what
/// keeps its count (the test fails when the policy moves none in).
#[test]
fn without_the_policy_robots_die_or_the_patrol_shrinks() {
    let none = short_day(Policy::None);
    assert_eq!(none.died, 6, "{none:?}");
    assert!(none.short_s > 1000.0 && none.worst_s > 600.0, "{none:?}");
    let naive = short_day(Policy::Naive);
    assert_eq!(naive.died, 0, "{naive:?}");
    assert!(naive.short_s > 300.0, "robots away unreplaced: {naive:?}");
    let reference = short_day(Policy::Unlimited);
    assert!(reference.worst_s < naive.worst_s && reference.errands == 0, "{reference:?} vs {naive:?}");
}

/// The day's worst idleness stays within 1.3 × its value without batteries (issue 53's target):
/// the spare waits where the low robot's leg ends, so a hand-over costs the team no metres (1.14 ×
/// here; 1.32 × when the spare went to where the low robot stood and swapped wherever they met).
#[test]
fn hand_overs_keep_the_worst_idleness_within_1_3_of_no_batteries() {
    let (mrmm, reference) = (short_day(Policy::Mrmm), short_day(Policy::Unlimited));
    assert!(mrmm.handovers >= 8, "{mrmm:?}");
    assert!(mrmm.worst_s <= 1.3 * reference.worst_s, "{} s against {} s without batteries", mrmm.worst_s, reference.worst_s);
}
