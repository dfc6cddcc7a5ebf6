//! Maps shipped with mrmm (`maps/data/`, sources and licences in its README): patrolling_sim's
//! navigation graphs, embedded for `mrmm experiment maps` and the tests.

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
