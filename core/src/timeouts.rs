//! How long each kind of query waits for its answer: declared once, used by the drivers
//! (`mrmm_manager::central`, `mrmm_manager::host`) and by the simulations alike.

/// A mission start: central asks a host to start (and plan) a mission.
pub const START_S: f64 = 25.0;
/// A plan: a mission's head asks a planner service.
pub const PLAN_S: f64 = 20.0;
/// A plan delivered: a mission's head gives a robot its plan.
pub const ROBOT_PLAN_S: f64 = 3.0;
/// Everything else central asks (a robot's info, a command, a mission's control or view): the
/// default of its `query_timeout_ms`.
pub const QUERY_S: f64 = 2.0;
