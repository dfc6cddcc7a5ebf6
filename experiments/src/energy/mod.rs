//! `mrmm experiment energy`: a patrol's working day on batteries. Six robots patrol every vertex
//! of Open-RMF's office graph (two chargers) for eight simulated hours, driven by the robots' own
//! executors and bodies (batteries included) as in `mrmm experiment maps`; central's charging
//! policy is the production machine (`mrmm_core::central::charging`), looked at once a second
//! as central does, its swaps handing the leaver's plan to the spare and its other moves
//! replanning the patrol as the mission's manager does (the patrol planner, from where the robots
//! stand). Four runs: no batteries (the reference), batteries
//! without charging (robots die), naive charging (each robot leaves when low and comes back when
//! charged, no spares), and mrmm's policy with two spares.

mod report;
mod world;

use anyhow::{anyhow, Context};
use mrmm_core::body::battery::BatteryModel;
use mrmm_core::central::charging::ChargingConfig;
use mrmm_maps::NavGraph;
use mrmm_planner::recipe::{self, Recipe};

use world::World;

pub use report::write;

/// The robots' top speed, m/s, and turn rate, rad/s.
const SPEED: f64 = 1.0;
const TURN: f64 = crate::maps::TURN;
/// Simulation step, s.
const DT: f64 = 0.05;
/// How often central's charging policy looks, s (the agent's look).
const LOOK_S: f64 = 1.0;
/// How often the figures' time series are sampled, s.
const SAMPLE_S: f64 = 60.0;
/// A robot within this distance of a vertex visits it, m.
const VISIT_R: f64 = 0.3;
/// The map: the shipped floor plan with two chargers.
const MAP: &str = "office";

/// How the fleet treats its batteries in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Policy {
    /// No batteries: the reference the others are measured against.
    Unlimited,
    /// Batteries and no charging: a robot that runs dry stops, and the patrol goes on without
    /// it (its manager replans at once: the kindest reading).
    None,
    /// Each robot leaves the patrol when low, charges, and comes back when charged; no spare
    /// takes its place (mrmm's policy with no idle robot in the fleet).
    Naive,
    /// mrmm's charging policy with the spares in the fleet: one takes the place of a robot that
    /// leaves to charge.
    Mrmm,
}

impl Policy {
    pub const ALL: [Policy; 4] = [Policy::Unlimited, Policy::None, Policy::Naive, Policy::Mrmm];

    pub fn name(self) -> &'static str {
        match self {
            Policy::Unlimited => "no batteries",
            Policy::None => "no charging",
            Policy::Naive => "naive charging",
            Policy::Mrmm => "mrmm (spares)",
        }
    }

    fn batteries(self) -> bool {
        self != Policy::Unlimited
    }

    fn charges(self) -> bool {
        matches!(self, Policy::Naive | Policy::Mrmm)
    }
}

/// The day: how long, the team, the batteries.
#[derive(Debug, Clone, PartialEq)]
pub struct Day {
    /// Simulated seconds.
    pub length_s: f64,
    /// Robots patrolling; the patrol's `min` is this too (the policy must keep it whole).
    pub team: usize,
    /// Idle robots in the fleet for mrmm's policy.
    pub spares: usize,
    /// A full charge drives this long at top speed, s.
    pub life_s: f64,
    /// A charger fills an empty battery in this long, s.
    pub charge_s: f64,
    /// The patrol's robots start with charges evenly spread from 1 down to this (robots come
    /// off their chargers in turn); spares start full.
    pub lowest_start: f64,
    pub charging: ChargingConfig,
    pub seed: u64,
}

impl Default for Day {
    fn default() -> Self {
        Day {
            length_s: 8.0 * 3600.0,
            team: 6,
            spares: 2,
            life_s: 2.0 * 3600.0,
            charge_s: 0.5 * 3600.0,
            lowest_start: 0.5,
            charging: ChargingConfig::default(),
            seed: 1,
        }
    }
}

impl Day {
    /// The batteries' model: [`BatteryModel::lasting`] the day's life, charged in `charge_s`.
    fn model(&self) -> BatteryModel {
        let m = BatteryModel::lasting(self.life_s, SPEED);
        BatteryModel { charge_w: m.capacity_wh * 3600.0 / self.charge_s, ..m }
    }
}

/// One run's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub policy: Policy,
    pub robots: usize,
    /// Idleness over the day (patrolling_sim's: average of each vertex's mean time between
    /// visits; worst: the longest), the time since its last visit at the day's end counted, s.
    pub avg_s: f64,
    pub worst_s: f64,
    /// Seconds the patrol had fewer robots than its team (its `min`).
    pub short_s: f64,
    /// The lowest charge any robot had, 0–1; robots ever below 5 %; robots that ran dry.
    pub lowest: f64,
    pub under_5: usize,
    pub died: usize,
    /// Charging errands started, times the patrol was replanned, and hand-overs (a spare took a
    /// leaving robot's plan, the others going on).
    pub errands: usize,
    pub replans: usize,
    pub handovers: usize,
    /// Simulated seconds robots stood plugged in, all robots together.
    pub charging_s: f64,
}

/// One run's time series, sampled every minute: robots patrolling and the lowest charge.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    pub policy: Policy,
    pub team: Vec<(f64, f64)>,
    pub lowest: Vec<(f64, f64)>,
}

/// Runs the day under every policy.
pub fn run(day: &Day) -> anyhow::Result<Vec<(Row, Trace)>> {
    let (name, text) = mrmm_maps::data::OPEN_RMF.iter().find(|(n, _)| *n == MAP).ok_or_else(|| anyhow!("the {MAP} graph is not shipped"))?;
    let graph = mrmm_maps::rmf::parse(name, text).map_err(|e| anyhow!("{e}"))?;
    let recipe = recipe::parse(recipe::bank("patrol").unwrap_or_default())?;
    let mut out = Vec::new();
    for policy in Policy::ALL {
        let started = std::time::Instant::now();
        let (row, trace) = one(day, &graph, &recipe, policy).with_context(|| policy.name())?;
        println!(
            "{:>15}: {} robots, idleness avg {:6.1} s worst {:6.1} s, short {:6.0} s, lowest charge {:4.2}, {} under 5 %, {} died, {} errands, {} replans, {} hand-overs ({:.1} s)",
            policy.name(),
            row.robots,
            row.avg_s,
            row.worst_s,
            row.short_s,
            row.lowest,
            row.under_5,
            row.died,
            row.errands,
            row.replans,
            row.handovers,
            started.elapsed().as_secs_f64()
        );
        out.push((row, trace));
    }
    Ok(out)
}

/// One policy's day.
pub fn one(day: &Day, graph: &NavGraph, recipe: &Recipe, policy: Policy) -> anyhow::Result<(Row, Trace)> {
    let mut w = World::new(day, graph, recipe, policy)?;
    w.replan()?;
    let steps = (day.length_s / DT).round() as u64;
    let every = |s: f64| (s / DT).round() as u64;
    for k in 0..steps {
        let t = k as f64 * DT;
        w.tick(t);
        w.step(t);
        if policy.charges() && k % every(LOOK_S) == 0 {
            w.look(t)?;
        }
        if w.changed {
            w.replan()?;
        }
        if k % every(SAMPLE_S) == 0 {
            w.sample(t);
        }
    }
    Ok(w.finish(day.length_s))
}

#[cfg(test)]
mod tests;
