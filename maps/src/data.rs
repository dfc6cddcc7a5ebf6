//! Maps shipped with mrmm (`maps/data/`, sources and licences in its README): patrolling_sim's
//! and Open-RMF's navigation graphs, embedded for `mrmm experiment maps`, `mrmm experiment
//! traffic` and the tests.

/// patrolling_sim's floor plans as navigation graphs: (name, `.graph` text).
pub const PATROLLING_SIM: [(&str, &str); 9] = [
    ("1r5", include_str!("../data/patrolling_sim/1r5.graph")),
    ("DIAG_floor1", include_str!("../data/patrolling_sim/DIAG_floor1.graph")),
    ("DIAG_labs", include_str!("../data/patrolling_sim/DIAG_labs.graph")),
    ("broughton", include_str!("../data/patrolling_sim/broughton.graph")),
    ("ctcv", include_str!("../data/patrolling_sim/ctcv.graph")),
    ("cumberland", include_str!("../data/patrolling_sim/cumberland.graph")),
    ("example", include_str!("../data/patrolling_sim/example.graph")),
    ("grid", include_str!("../data/patrolling_sim/grid.graph")),
    ("move_base_arena", include_str!("../data/patrolling_sim/move_base_arena.graph")),
];

/// Open-RMF's office demo as a navigation graph: (name, `nav_graphs/<n>.yaml` text).
pub const OPEN_RMF: [(&str, &str); 1] = [("office", include_str!("../data/open_rmf/office.nav_graph.yaml"))];

/// Every shipped navigation graph, read: patrolling_sim's, then Open-RMF's.
pub fn graphs() -> Result<Vec<(&'static str, crate::NavGraph)>, crate::MapError> {
    let ps = PATROLLING_SIM.iter().map(|(name, text)| crate::patrolling_sim::parse(name, text).map(|g| (*name, g)));
    let rmf = OPEN_RMF.iter().map(|(name, text)| crate::rmf::parse(name, text).map(|g| (*name, g)));
    ps.chain(rmf).collect()
}
