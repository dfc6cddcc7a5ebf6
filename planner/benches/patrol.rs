//! Patrol planning benchmark: time to plan a patrol for teams of 50 to 1 000 robots on the
//! demo's six-waypoint tour (~70 m), robots in rows of 20 below it as `mrmm demo` starts them,
//! and the time until the last robot is in its slot.
//!
//! `cargo bench -p mrmm-planner --bench patrol [-- N …]` (default 50 100 150 225 300 500 1000)

use std::time::Instant;

use mrmm_planner::geom::Point;
use mrmm_planner::patrol::{self, PatrolParams};
use mrmm_proto::plan::RobotSpec;

fn main() {
    let mut sizes: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    if sizes.is_empty() {
        sizes = vec![50, 100, 150, 225, 300, 500, 1000];
    }
    let tour = [(-15., 4.), (-6., 14.), (5., 17.), (15., 9.), (11., 1.), (0., 0.)].map(|(x, y)| Point::new(x, y)).to_vec();
    println!("| robots | plan ms | formation s | predicted worst idleness s |");
    println!("|---:|---:|---:|---:|");
    for n in sizes {
        let robots: Vec<RobotSpec> = (0..n)
            .map(|i| RobotSpec {
                id: format!("r{}", i + 1).into(),
                robot_type: "ground".into(),
                x: ((i % 20) as f64 - 9.5) * 1.5,
                y: -12.0 - (i / 20) as f64 * 1.5,
                speed: 1.0,
                turn_rate: None,
                reach_m: None,
            })
            .collect();
        let t = Instant::now();
        match patrol::plan(&PatrolParams::new(tour.clone()), &robots) {
            Ok(p) => println!("| {n} | {:.0} | {:.1} | {:.2} |", t.elapsed().as_secs_f64() * 1e3, p.formation_time, p.predicted_worst_idleness),
            Err(e) => eprintln!("{n} robots: {e}"),
        }
    }
}
