//! Coverage benchmark: coverage radius against the hexagonal covering bound, and time, for a
//! square, an L-shaped region and a square with a hole.
//!
//! `cargo bench -p mrmm-planner --bench coverage`

use std::time::Instant;

use mrmm_planner::coverage::{self, CoverageParams};
use mrmm_planner::geom::Point;
use mrmm_planner::region::Region;

fn pts(v: &[(f64, f64)]) -> Vec<Point> {
    v.iter().map(|&(x, y)| Point::new(x, y)).collect()
}

fn main() {
    let regions = [
        ("square 100×100", pts(&[(0., 0.), (100., 0.), (100., 100.), (0., 100.)]), vec![]),
        ("L-shape", pts(&[(0., 0.), (100., 0.), (100., 40.), (40., 40.), (40., 100.), (0., 100.)]), vec![]),
        ("square with hole", pts(&[(0., 0.), (100., 0.), (100., 100.), (0., 100.)]), vec![pts(&[(35., 35.), (65., 35.), (65., 65.), (35., 65.)])]),
    ];
    println!("| region | n | coverage radius | hexagonal bound | ratio | time ms |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (name, outer, holes) in regions {
        let region = match Region::new(outer, holes) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("{name}: {e}");
                continue;
            }
        };
        for n in [4usize, 9, 16, 25, 50] {
            let t = Instant::now();
            let params = CoverageParams::new(region.clone());
            let Ok((_, r)) = coverage::place(&region, n, &params) else { continue };
            let ms = t.elapsed().as_secs_f64() * 1e3;
            let bound = coverage::hexagonal_bound(region.area(), n);
            println!("| {name} | {n} | {r:.2} | {bound:.2} | {:.3} | {ms:.0} |", r / bound);
        }
    }
}
