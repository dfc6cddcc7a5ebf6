//! Start tours: greedy edge matching over the neighbour lists, fragments joined greedily.

use super::Instance;

/// Greedy-edge tour: shortest candidate edges first while degrees stay ≤ 2 and no early cycle
/// closes; the remaining path fragments are joined nearest-endpoint first.
pub fn greedy(inst: &Instance, neigh: &[Vec<u32>]) -> Vec<usize> {
    let n = inst.len();
    let mut edges: Vec<(f64, u32, u32)> = Vec::with_capacity(n * neigh.first().map_or(0, Vec::len));
    for (i, list) in neigh.iter().enumerate() {
        for &j in list {
            if (i as u32) < j {
                edges.push((inst.d(i, j as usize), i as u32, j));
            }
        }
    }
    edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut adj = vec![[u32::MAX; 2]; n];
    let mut deg = vec![0u8; n];
    let mut uf = UnionFind::new(n);
    let mut added = 0;
    for &(_, a, b) in &edges {
        let (a, b) = (a as usize, b as usize);
        if deg[a] < 2 && deg[b] < 2 && uf.union(a, b) {
            adj[a][deg[a] as usize] = b as u32;
            adj[b][deg[b] as usize] = a as u32;
            deg[a] += 1;
            deg[b] += 1;
            added += 1;
            if added == n - 1 {
                break;
            }
        }
    }
    // Join fragments: walk from an endpoint, then jump to the nearest free endpoint.
    let mut order = Vec::with_capacity(n);
    let mut visited = vec![false; n];
    let mut cur = (0..n).find(|&i| deg[i] < 2).unwrap_or(0);
    loop {
        // Walk the fragment containing `cur` from its endpoint `cur`.
        let mut prev = u32::MAX;
        loop {
            visited[cur] = true;
            order.push(cur);
            let next = adj[cur].iter().copied().find(|&x| x != u32::MAX && x != prev && !visited[x as usize]);
            match next {
                Some(x) => {
                    prev = cur as u32;
                    cur = x as usize;
                }
                None => break,
            }
        }
        if order.len() == n {
            break;
        }
        // Nearest unvisited fragment endpoint (degree < 2), brute force over endpoints.
        let from = cur;
        let mut best = (f64::INFINITY, usize::MAX);
        for i in 0..n {
            if !visited[i] && deg[i] < 2 {
                let d = inst.d(from, i);
                if d < best.0 {
                    best = (d, i);
                }
            }
        }
        if best.1 == usize::MAX {
            // Only possible with a closed fragment, which union-find prevents; be safe anyway.
            best.1 = (0..n).find(|&i| !visited[i]).unwrap_or(0);
        }
        cur = best.1;
    }
    order
}

struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        UnionFind { parent: (0..n as u32).collect() }
    }
    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let p = self.parent[x] as usize;
            self.parent[x] = self.parent[p];
            x = p;
        }
        x
    }
    /// Joins the sets of a and b; false if they were already joined.
    fn union(&mut self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        self.parent[ra] = rb as u32;
        true
    }
}
