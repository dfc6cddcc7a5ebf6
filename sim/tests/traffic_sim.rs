//! Seeded simulation of traffic (`mrmm_sim::traffic`): robots driving random routes on real
//! floor plans — patrolling_sim's nine navigation graphs and Open-RMF's office graph, as shipped in
//! `maps/data` — never come closer than the clearance, and every robot keeps finishing routes.
//! Blind, the same robots meet: the check can see a meeting.
//!
//! `MRMM_SIM_SEEDS=N` runs N seeds per map (default 20); `MRMM_SIM_SEED=S` replays one seed on
//! every map and prints its report.

use std::sync::Arc;

use mrmm_core::traffic::Layout;
use mrmm_maps::space::GraphSpace;
use mrmm_sim::traffic::{run, Report, World};

/// Robots are 0.25 m in radius: centres stay 0.6 m apart.
const CLEARANCE: f64 = 0.6;

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn runs(world: World) -> Vec<(&'static str, Report)> {
    runs_cut(world, None)
}

/// The runs on every map, its lanes cut into segments of at most `cut` metres if given.
fn runs_cut(world: World, cut: Option<f64>) -> Vec<(&'static str, Report)> {
    runs_on(world, |g| cut.map_or(g.clone(), |m| mrmm_core::traffic::layout::segmented(g, m)))
}

/// The runs on every map, laid out for traffic by `lay`.
fn runs_on(mut world: World, lay: impl Fn(&mrmm_maps::NavGraph) -> mrmm_maps::NavGraph) -> Vec<(&'static str, Report)> {
    let seeds: Vec<u64> = match env_u64("MRMM_SIM_SEED") {
        Some(s) => {
            world.trace = true;
            vec![s]
        }
        None => (0..env_u64("MRMM_SIM_SEEDS").unwrap_or(20)).collect(),
    };
    let mut out = Vec::new();
    for (name, graph) in mrmm_maps::data::graphs().expect("shipped maps read") {
        let per = env_u64("MRMM_TRAFFIC_PER").unwrap_or(10) as usize;
        let world = World { robots: world.robots.min(graph.vertices.len() / per).max(2), ..world };
        let places = Some(graph.vertices.len() as u32);
        let world = World { places, ..world };
        let graph = lay(&graph);
        let layout = Arc::new(Layout::new(&graph, CLEARANCE));
        let space = GraphSpace::new(&graph);
        for &seed in &seeds {
            match run(&layout, &space, world, seed) {
                Ok(r) => out.push((name, r)),
                Err(v) => panic!("{name}: {v}; replay with MRMM_SIM_SEED={} cargo test -p mrmm-sim --test traffic_sim", v.seed),
            }
        }
    }
    if seeds.len() == 1 {
        for (name, r) in &out {
            println!("{name}: {r:?}", r = Report { trace: vec![], ..r.clone() });
        }
    }
    out
}

#[test]
fn robots_never_meet_and_keep_going() {
    let reports = runs(World { robots: 12, duration: 600.0, ..World::default() });
    for (name, r) in &reports {
        assert!(r.closest >= CLEARANCE - 1e-6, "{name} seed {}: {r:?}", r.seed);
    }
    let sum = |f: fn(&Report) -> u64| reports.iter().map(|(_, r)| f(r)).sum::<u64>();
    let robot_runs = reports.iter().map(|(_, r)| r.robots as u64).sum::<u64>();
    println!(
        "{robot_runs} robot-runs: trips {} detours {} blocked {} stalled {}",
        sum(|r| r.trips),
        sum(|r| r.detours),
        sum(|r| r.blocked),
        sum(|r| r.stalled)
    );
    for (name, r) in reports.iter().filter(|(_, r)| r.stalled > 0) {
        println!("{name} seed {}: {} stalled", r.seed, r.stalled);
    }
    // Gridlocks traffic cannot break are rare at this density: at most one robot-run in 100
    // stands five minutes wanting to drive.
    assert!(sum(|r| r.stalled) * 100 <= robot_runs, "{} stalls in {robot_runs} robot-runs", sum(|r| r.stalled));
    assert!(sum(|r| r.detours) > 0 && sum(|r| r.trips) > robot_runs * 5);
}

#[test]
fn blind_robots_meet() {
    let reports = runs(World { robots: 12, duration: 600.0, controlled: false, ..World::default() });
    let met = reports.iter().filter(|(_, r)| r.too_close > 0).count();
    println!("trips {}, {met} of {} runs with robots meeting", reports.iter().map(|(_, r)| r.trips).sum::<u64>(), reports.len());
    assert!(met * 2 > reports.len(), "only {met} of {} blind runs had robots meeting", reports.len());
}

/// Robots that tell traffic when they are clear of the vertex behind them (`Event::Left`), so
/// that a follower closes up to it: still never closer than the clearance, on whole lanes, on
/// lanes cut at 3 m (with the clearance alone, no wider where lanes leave a vertex at a sharp
/// angle, two came 0.596 m apart: cumberland, seed 8) and as the fleet cuts them now.
#[test]
fn robots_letting_go_behind_them_never_meet() {
    for cut in [None, Some(3.0), Some(mrmm_core::traffic::authority::SEGMENT_M)] {
        let reports = runs_cut(World { robots: 12, duration: 600.0, release: true, ..World::default() }, cut);
        for (name, r) in &reports {
            assert!(r.closest >= CLEARANCE - 1e-6, "{name} seed {} (cut {cut:?}): {r:?}", r.seed);
        }
        let robot_runs = reports.iter().map(|(_, r)| r.robots as u64).sum::<u64>();
        assert!(reports.iter().map(|(_, r)| r.trips).sum::<u64>() > robot_runs * 5);
    }
}

/// Every two-way lane of 1.5 m or more marked passing (a side each way, to its right), cut as
/// the fleet cuts lanes: robots still never come closer than the clearance, none stalls, and
/// together they finish more trips than on the same lanes drawn single file.
#[test]
fn robots_on_passing_lanes_never_meet_and_finish_more_trips() {
    use mrmm_core::traffic::{authority::SEGMENT_M, layout::segmented};
    let world = World { robots: 12, duration: 600.0, release: true, ..World::default() };
    let passing = runs_on(world, |g| segmented(&g.clone().with_passing(1.5), SEGMENT_M));
    for (name, r) in &passing {
        assert!(r.closest >= CLEARANCE - 1e-6, "{name} seed {}: {r:?}", r.seed);
        assert_eq!(r.stalled, 0, "{name} seed {}: {r:?}", r.seed);
    }
    let trips = |reports: &[(&str, Report)]| reports.iter().map(|(_, r)| r.trips).sum::<u64>();
    let single = runs_cut(world, Some(SEGMENT_M));
    println!("trips: {} passing, {} single file", trips(&passing), trips(&single));
    assert!(trips(&passing) > trips(&single), "passing {} single file {}", trips(&passing), trips(&single));
}

/// Seeds whose robots stalled for good in corridor gridlocks no single robot could step out of
/// (12 robots, lanes cut at 3 m as the fleet cuts them, start and goals on the map's own
/// vertices, as `mrmm experiment traffic` runs them): the cycle's oldest robot now pushes the
/// queue in its way back as a train (`traffic/push.rs`). Each stalled without it. Seed 18 stalled
/// again (13 097 routes given in 600 s) once robots stepped aside off the whole of each other's
/// ways: a search's plan that moved two robots only on along their own routes was taken for a
/// change, and looked for again at every tick (`Traffic::changes_way`).
#[test]
fn queues_in_corridors_are_pushed_back_as_trains() {
    for (map, seed) in [("DIAG_floor1", 12), ("DIAG_floor1", 14), ("DIAG_floor1", 18), ("cumberland", 6)] {
        no_stall(map, World { robots: 12, ..World::default() }, seed);
    }
}

/// `world` on shipped map `map`, its lanes cut at 3 m (as the fleet cut them when these seeds
/// were found), robots starting and going to the map's own vertices (as `mrmm experiment
/// traffic` runs them): no robot stalls, none comes closer than the clearance.
fn no_stall(map: &str, world: World, seed: u64) {
    no_stall_cut(map, world, seed, 3.0);
}

/// [`no_stall`], the lanes cut at `cut` metres.
fn no_stall_cut(map: &str, world: World, seed: u64, cut: f64) {
    let maps = mrmm_maps::data::graphs().expect("shipped maps read");
    let (_, graph) = maps.iter().find(|(name, _)| *name == map).expect("the map is shipped");
    let cut = mrmm_core::traffic::layout::segmented(graph, cut);
    let layout = Arc::new(Layout::new(&cut, CLEARANCE));
    let world = World { places: Some(graph.vertices.len() as u32), ..world };
    let r = run(&layout, &GraphSpace::new(&cut), world, seed).unwrap_or_else(|v| panic!("{map}: {v}"));
    assert_eq!(r.stalled, 0, "{map} seed {seed}: {r:?}", r = Report { trace: vec![], ..r.clone() });
    assert!(r.closest >= CLEARANCE - 1e-6, "{map} seed {seed}: {}", r.closest);
}

/// Seeds whose robots stepped back and forth for good: two cycles of waits round a junction,
/// each broken by a step aside that recreated the other (office: a robot sent into a pocket
/// and out again while three robots held the three ends of the junction beside it). A step
/// aside a robot made twice on one way is now tried after every other robot's. Robots report
/// as they pass the release point (as the fleet's do). Each stalled without it.
#[test]
fn cycles_undoing_each_others_steps_aside_are_broken_another_way() {
    for (map, robots, seed) in [("office", 8, 9), ("cumberland", 12, 6)] {
        no_stall(map, World { robots, release: true, ..World::default() }, seed);
    }
}

/// Seeds whose gridlocks no step aside or push broke (DIAG's crowded corridor 95 – 103 with
/// robots both ways and its pockets full; a queue in DIAG_labs): a short search over the moves
/// of up to nine robots standing on and beside the way of the robot that waited longest clears
/// it (`traffic/search.rs`). Robots report as they pass
/// the release point. Each stalled without the search.
#[test]
fn gridlocks_no_step_or_push_breaks_are_searched_out() {
    for (map, robots, seed) in [("DIAG_floor1", 12, 3), ("DIAG_floor1", 12, 12), ("DIAG_floor1", 12, 26), ("DIAG_labs", 8, 24)] {
        no_stall(map, World { robots, release: true, ..World::default() }, seed);
    }
}

/// Seeds whose gridlocks lay in corridors longer than a search reaches (ctcv, a line of 30
/// segments with a dead end at its east end: three robots followed each other in while a fourth
/// came out; DIAG_floor1's corridor at 12 robots): the robots on the oldest robot's way are sent
/// ahead of it to free places off it (`traffic/clear.rs`). Cut at 3 m. Each stalled without it.
#[test]
fn corridors_are_cleared_ahead_of_the_oldest_robot() {
    for (map, robots, seed) in [("ctcv", 4, 9), ("DIAG_floor1", 12, 18)] {
        no_stall(map, World { robots, release: true, ..World::default() }, seed);
    }
}

/// Seeds found with lanes cut at 1.5 m (the fleet's cut since they were found). ctcv, two
/// robots: one stepped aside into the dead end the other was going to, and as nothing changed
/// after that no one looked again — a gridlock is now looked at again once its robots have
/// waited long enough for a search. move_base_arena draws one lane over another (vertices 0
/// and 2 at one place): a robot stepped aside to a vertex beside the other's way, not off it.
/// Each stalled without its fix.
#[test]
fn gridlocks_on_short_segments_are_looked_at_again_and_stepped_out_of() {
    for (map, robots, seed) in [("ctcv", 2, 100), ("move_base_arena", 2, 8)] {
        no_stall_cut(map, World { robots, release: true, ..World::default() }, seed, 1.5);
    }
}

/// Seeds that stalled with lanes cut as the fleet cuts them (seeds 1 – 100 of every map and size):
/// robots had stepped aside only six vertices off the way of those they made way for — on
/// segments of 1.5 m, back onto it a few metres on — and the one that asked last stepped aside
/// first, however far it had to go. Robots now step off the whole of each other's ways, the
/// cheapest step first (`traffic/deadlock.rs`).
#[test]
fn robots_step_off_the_whole_way_the_cheapest_step_first() {
    for (map, seed) in [("ctcv", 53), ("move_base_arena", 75)] {
        no_stall_cut(map, World { robots: 4, release: true, ..World::default() }, seed, mrmm_core::traffic::authority::SEGMENT_M);
    }
}

/// move_base_arena draws lanes 0 – 1 and 2 – 1 one over the other (vertices 0 and 2 at one
/// place), 4 robots, seed 84: two robots head-on on the twin lanes, two more swapping at the
/// junction below. The oldest one's search left out the robot on the twin lane (not within hops
/// of its way by the graph) and no other robot of the gridlock was searched for. A search's
/// region now takes in what is in conflict with it, and each robot of the gridlock is searched
/// for in turn. Stalled without.
#[test]
fn a_lane_drawn_over_another_is_searched_as_one() {
    no_stall_cut("move_base_arena", World { robots: 4, release: true, ..World::default() }, 84, mrmm_core::traffic::authority::SEGMENT_M);
}

/// A robot starved outside any cycle of waits (DIAG_labs, 8 robots, seed 6, lanes cut as the
/// fleet cuts them): at a dead end's mouth it needed the junction and the vertex past it free at
/// once, while the robots of the busy corridor there took them in turn for 300 s — none of them
/// waited for it, so no cycle, push or search was ever looked for. Once it has waited
/// `STARVED_S` the robots on its way are searched out of it or sent ahead of it. Stalled without.
#[test]
fn a_robot_starved_by_a_busy_corridor_has_its_way_cleared() {
    no_stall_cut("DIAG_labs", World { robots: 8, release: true, ..World::default() }, 6, mrmm_core::traffic::authority::SEGMENT_M);
}
