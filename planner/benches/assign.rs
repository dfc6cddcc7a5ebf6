//! Assignment benchmark: dense random n×n matrices (uniform costs), min-sum and bottleneck.
//!
//! `cargo bench -p mrmm-planner --bench assign [-- N [REPEATS]]` (default 1000, 5).

use std::time::Instant;

use mrmm_planner::assign::{bottleneck, min_sum, Costs};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let reps: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let mut sum_ms = Vec::new();
    let mut bn_ms = Vec::new();
    for seed in 0..reps {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let data = (0..n * n).map(|_| rng.gen_range(0.0..1.0)).collect();
        let c = match Costs::new(n, n, data) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let t = Instant::now();
        let a = min_sum(&c);
        sum_ms.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let b = bottleneck(&c);
        bn_ms.push(t.elapsed().as_secs_f64() * 1e3);
        println!(
            "seed {seed}: min-sum total {:.4} ({:.1} ms), bottleneck max {:.5} ({:.1} ms)",
            a.total,
            sum_ms[sum_ms.len() - 1],
            b.max,
            bn_ms[bn_ms.len() - 1]
        );
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!("n = {n}: min-sum median {:.1} ms, bottleneck median {:.1} ms over {reps} matrices", med(&mut sum_ms), med(&mut bn_ms));
}
