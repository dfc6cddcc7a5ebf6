//! Every TSPLIB instance in tests/data/tsplib (committed, with its source): parses, and the solver returns a valid closed tour
//! (a permutation) whose reported length is the recomputed length and never below the optimum.
//! Quality and speed are measured by `cargo bench --bench tsplib`, not asserted here.

use std::path::PathBuf;

use mrmm_planner::tsp::{self, Budget};
use mrmm_planner::tsplib;

#[test]
fn every_instance_gives_a_valid_tour() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/tsplib");
    let optima = std::fs::read_to_string(dir.join("optima.txt")).expect("tests/data/tsplib/optima.txt");
    let mut count = 0;
    for line in optima.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
        let mut it = line.split_whitespace();
        let name = it.next().expect("name");
        let opt: f64 = it.next().and_then(|v| v.parse().ok()).expect("optimum");
        let text = std::fs::read_to_string(dir.join(format!("{name}.tsp"))).expect("instance");
        let inst = tsplib::parse(&text).unwrap_or_else(|e| panic!("{name}: {e}")).instance;
        let (tour, _) = tsp::solve(&inst, &Budget { max_kicks: 30, stop: None, seed: 7 }).expect("solve");
        assert!(tsp::is_permutation(&tour.order, inst.len()), "{name}: not a permutation");
        assert_eq!(tour.order[0], 0, "{name}: starts at node 1");
        assert_eq!(tour.length, inst.tour_length(&tour.order), "{name}: length");
        assert!(tour.length >= opt, "{name}: {} below the optimum {opt}", tour.length);
        assert!(tour.length <= opt * 1.15, "{name}: {} more than 15 % above {opt} even after local search", tour.length);
        count += 1;
    }
    assert_eq!(count, 20, "all instances of optima.txt");
}
