//! Exact tours for small instances (Held-Karp dynamic programming, O(2^n n^2)).

use super::Instance;

/// Optimal visiting order starting at 0. Meant for n ≤ 16.
pub fn held_karp(inst: &Instance) -> Vec<usize> {
    let n = inst.len();
    if n <= 3 {
        return (0..n).collect();
    }
    let m = n - 1; // cities 1..n as bits 0..m
    let full = 1usize << m;
    let mut cost = vec![f64::INFINITY; full * m];
    let mut parent = vec![u8::MAX; full * m];
    for j in 0..m {
        cost[(1 << j) * m + j] = inst.d(0, j + 1);
    }
    for set in 1..full {
        for j in 0..m {
            if set & (1 << j) == 0 {
                continue;
            }
            let c = cost[set * m + j];
            if !c.is_finite() {
                continue;
            }
            for k in 0..m {
                if set & (1 << k) != 0 {
                    continue;
                }
                let next = set | (1 << k);
                let nc = c + inst.d(j + 1, k + 1);
                if nc < cost[next * m + k] {
                    cost[next * m + k] = nc;
                    parent[next * m + k] = j as u8;
                }
            }
        }
    }
    let last_set = full - 1;
    let mut best = (f64::INFINITY, 0);
    for j in 0..m {
        let c = cost[last_set * m + j] + inst.d(j + 1, 0);
        if c < best.0 {
            best = (c, j);
        }
    }
    let mut order = Vec::with_capacity(n);
    let (mut set, mut j) = (last_set, best.1);
    loop {
        order.push(j + 1);
        let p = parent[set * m + j];
        set &= !(1 << j);
        if p == u8::MAX {
            break;
        }
        j = p as usize;
    }
    order.push(0);
    order.reverse();
    order
}
