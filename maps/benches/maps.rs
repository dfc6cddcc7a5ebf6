//! Map benchmark: reading a large occupancy grid, preparing it for planning, and the distance
//! matrix of 100 waypoints on it (target ≤ 1 s), and the same on a 200-vertex graph (target
//! ≤ 50 ms). Median of 5 runs each. `cargo bench -p mrmm-maps --bench maps`.
//!
//! The grid is drawn here: 2 000 × 1 000 cells of 0.05 m (100 × 50 m), a storey of 10 × 5 rooms
//! off two corridors, doors 1 m wide, walls 0.15 m thick, encoded as a map_saver PGM + YAML.

use std::time::Instant;

use mrmm_maps::graph::{Edge, Vertex};
use mrmm_maps::{Bundle, Map, NavGraph, Node, Point, Space};
use rand::{Rng, SeedableRng};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut ms = Vec::new();
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        out = Some(f());
        ms.push(t.elapsed().as_secs_f64() * 1000.0);
    }
    (median(ms), out.expect("one run"))
}

/// The storey as a PGM (row 0 at the top) and its YAML.
fn storey() -> Bundle {
    let (w, h, res) = (2000usize, 1000usize, 0.05);
    let mut occ = vec![false; w * h]; // (col, row from the bottom)
    let mut wall = |x0: f64, y0: f64, x1: f64, y1: f64| {
        let (c0, c1) = ((x0 / res) as usize, ((x1 / res) as usize).min(w));
        let (r0, r1) = ((y0 / res) as usize, ((y1 / res) as usize).min(h));
        for r in r0..r1 {
            for c in c0..c1 {
                occ[r * w + c] = true;
            }
        }
    };
    let t = 0.15;
    // Outer walls, two corridors at y 15-18 and 32-35, rooms between.
    wall(0.0, 0.0, 100.0, t);
    wall(0.0, 50.0 - t, 100.0, 50.0);
    wall(0.0, 0.0, t, 50.0);
    wall(100.0 - t, 0.0, 100.0, 50.0);
    for y in [15.0, 18.0, 32.0, 35.0] {
        for k in 0..10 {
            let x = k as f64 * 10.0;
            // A door in the middle of each room's corridor wall.
            wall(x, y, x + 4.5, y + t);
            wall(x + 5.5, y, x + 10.0, y + t);
        }
    }
    for k in 1..10 {
        let x = k as f64 * 10.0;
        for (y0, y1) in [(0.0, 15.0), (18.0, 32.0), (35.0, 50.0)] {
            wall(x, y0, x + t, y1);
        }
    }
    let mut pgm = format!("P5\n# CREATOR: mrmm bench\n{w} {h}\n255\n").into_bytes();
    for row in (0..h).rev() {
        pgm.extend(occ[row * w..(row + 1) * w].iter().map(|&o| if o { 0u8 } else { 254u8 }));
    }
    let yaml = "image: storey.pgm\nmode: trinary\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
    let mut files = std::collections::BTreeMap::new();
    files.insert("storey.yaml".to_string(), yaml.as_bytes().to_vec());
    files.insert("storey.pgm".to_string(), pgm);
    Bundle { main: "storey.yaml".into(), files }
}

/// A 10 × 20 lattice of vertices 3 m apart with both diagonals in every other cell: 200 vertices.
fn lattice() -> NavGraph {
    let (cols, rows) = (20u32, 10u32);
    let vertices = (0..rows * cols)
        .map(|i| Vertex { charger: false, name: i.to_string(), at: Point::new((i % cols) as f64 * 3.0, (i / cols) as f64 * 3.0) })
        .collect::<Vec<_>>();
    let mut edges = Vec::new();
    let mut join = |a: u32, b: u32, vs: &[Vertex]| {
        let l = vs[a as usize].at.dist(vs[b as usize].at);
        edges.push(Edge { from: a, to: b, length: l, passing: false });
        edges.push(Edge { from: b, to: a, length: l, passing: false });
    };
    for r in 0..rows {
        for c in 0..cols {
            let i = r * cols + c;
            if c + 1 < cols {
                join(i, i + 1, &vertices);
            }
            if r + 1 < rows {
                join(i, i + cols, &vertices);
                if (r + c) % 2 == 0 && c + 1 < cols {
                    join(i, i + cols + 1, &vertices);
                }
            }
        }
    }
    NavGraph { vertices, edges }
}

fn main() {
    let threads = std::thread::available_parallelism().map_or(1, |t| t.get());
    println!("machine: {threads} hardware threads (the distance matrix uses up to 8)");
    let bundle = storey();
    let (load_ms, (_, map)) = time(5, || bundle.load().expect("the storey loads"));
    let (space_ms, space) = time(5, || Space::new(&map, 0.25).expect("space"));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let mut nodes: Vec<Node> = Vec::new();
    while nodes.len() < 100 {
        let p = Point::new(rng.gen_range(1.0..99.0), rng.gen_range(1.0..49.0));
        if let Ok(n) = space.locate("waypoint", nodes.len(), p) {
            nodes.push(n);
        }
    }
    let (matrix_ms, d) = time(5, || space.matrix(&nodes));
    assert!(d.iter().all(|v| v.is_finite()), "every room is reachable");
    let (route_ms, _) = time(5, || (0..99).map(|i| space.route(&nodes[i], &nodes[i + 1]).expect("route").len()).sum::<usize>());
    println!("grid 2000 × 1000 cells (0.05 m): load {load_ms:.0} ms, prepare (inflate 0.25 m, planning grid) {space_ms:.0} ms, 100 × 100 distance matrix {matrix_ms:.0} ms (target ≤ 1000 ms incl. prepare: {:.0} ms), 99 routes {route_ms:.0} ms", space_ms + matrix_ms);

    let graph = lattice();
    let gmap = Map::Graph(graph.clone());
    let (g_ms, gd) = time(5, || {
        let s = Space::new(&gmap, 0.0).expect("space");
        let nodes: Vec<Node> = (0..graph.vertices.len() as u32).filter_map(|i| s.node_at(i)).collect();
        s.matrix(&nodes)
    });
    assert!(gd.iter().all(|v| v.is_finite()));
    println!("graph of {} vertices, {} edges: 200 × 200 distance matrix {g_ms:.1} ms (target ≤ 50 ms)", graph.vertices.len(), graph.edges.len());
}
