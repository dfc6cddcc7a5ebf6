//! `mrmm experiment traffic`: robots sharing the corridors of real floor plans — patrolling_sim's
//! nine navigation graphs and Open-RMF's office — under traffic (`mrmm_core::traffic`) and
//! blind, in the seeded simulation `mrmm_sim::traffic`: trips driven, how close robots
//! came, how long they waited, how often traffic made one step aside or could not break a
//! gridlock, and what an event costs the machine.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{anyhow, Context};
use mrmm_core::traffic::Layout;
use mrmm_maps::space::GraphSpace;
use mrmm_sim::traffic::{self as sim, Report, World};

/// Team sizes by default (each map takes those of at most a third of its vertices).
pub const SIZES: [usize; 4] = [2, 4, 8, 12];
/// Seeds per map and size.
const SEEDS: u64 = 10;
/// Robots 0.25 m in radius keep their centres this far apart, m.
const CLEARANCE: f64 = 0.6;

/// How the lanes are held: cut into segments of at most `segment` metres (0: whole), corridors
/// locked by direction, the vertex behind a robot let go once it is clear of it; two-way lanes
/// at least `passing` metres long marked passing (0: as the maps draw them); with `floor`, the
/// lanes marked passing where the map's floor plan has room ([`floor_plan`]).
#[derive(Debug, Clone, Copy)]
pub struct Lanes {
    pub segment: f64,
    pub corridors: bool,
    pub release: bool,
    pub passing: f64,
    pub floor: bool,
}

/// Where the shipped floor plans are (patrolling_sim's, beside their graphs; in the repository).
const FLOOR_PLANS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../maps/data/patrolling_sim/");

/// `graph` with its two-way lanes marked passing where map `name`'s floor plan (a Nav2 map
/// shipped beside its graph) has room for two robots side by side, read as the fleet reads a
/// graph central is given with its plan (`floor_plans`: [`mrmm_maps::Bundle::collect_on_plan`]);
/// unmarked if it has none.
fn floor_plan(name: &str, graph: &mrmm_maps::NavGraph) -> anyhow::Result<mrmm_maps::NavGraph> {
    let (path, yaml) = (format!("{FLOOR_PLANS}{name}.graph"), format!("{FLOOR_PLANS}{name}.yaml"));
    if !Path::new(&yaml).exists() {
        return Ok(graph.clone());
    }
    let bundle = mrmm_maps::Bundle::collect_on_plan(&path, &yaml, |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow!("{e}"))?;
    match bundle.load().map_err(|e| anyhow!("{e}"))?.1 {
        mrmm_maps::Map::Graph(g) => Ok(g),
        mrmm_maps::Map::Grid(_) => Err(anyhow!("{path}: not a navigation graph")),
    }
}

/// One map and team size, over the seeds.
pub struct Row {
    pub map: String,
    pub vertices: usize,
    pub robots: usize,
    pub seeds: u64,
    pub blind_trips: u64,
    /// Runs in which blind robots came closer than the clearance.
    pub blind_met: u64,
    pub trips: u64,
    /// Closest two robots under traffic came, m.
    pub closest: f64,
    pub too_close: u64,
    pub detours: u64,
    pub blocked: u64,
    pub stalled: u64,
    /// Share of the robots' time spent standing for a grant.
    pub waiting: f64,
    /// Of it, what they waited for (shares of the robots' time): parked robots, queued ones,
    /// oncoming ones, ones ahead or crossing, anything else.
    pub waited_for: [f64; 5],
    /// Wall microseconds per event handled by traffic (this machine).
    pub us_per_event: f64,
    /// Goals reached by lifelong PIBT on the map cut into clearance-sized moves
    /// (`mrmm_sim::traffic::pibt`), and by the same discrete robots driving blindly.
    pub reference_trips: u64,
    pub reference_blind: u64,
}

/// Every map with every team size that fits it.
pub fn run(out: &Path, sizes: &[usize], seed: u64, lanes: Lanes) -> anyhow::Result<Vec<Row>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let maps = mrmm_maps::data::graphs().map_err(|e| anyhow!("{e}"))?;
    let mut rows = Vec::new();
    for (name, graph) in &maps {
        // Robots start and go to the map's own vertices; cut lanes add vertices after them.
        let marked = if lanes.floor {
            let g = floor_plan(name, graph)?;
            println!("{name:>16}: {} of {} lanes passing on its floor plan", g.summary().passing, g.lanes().len());
            g
        } else if lanes.passing > 0.0 {
            graph.clone().with_passing(lanes.passing)
        } else {
            graph.clone()
        };
        let cut = if lanes.segment > 0.0 { mrmm_core::traffic::layout::segmented(&marked, lanes.segment) } else { marked };
        let layout = Arc::new(Layout::new(&cut, CLEARANCE));
        let space = GraphSpace::new(&cut);
        for &n in sizes.iter().filter(|&&n| n >= 1 && n * 3 <= graph.vertices.len()) {
            let mut row = one(name, graph.vertices.len(), &layout, &space, n, seed, lanes)?;
            reference(&mut row, graph, seed)?;
            println!(
                "{name:>16} {:>3} vertices {n:>2} robots: trips {:>5} (blind {:>5}, {:.0} %), closest {:.2} m (blind robots met in {} of {} runs), waiting {:.0} %, {} steps aside, {} stalled, {:.1} µs/event; PIBT keeps {:.0} %",
                row.vertices,
                row.trips,
                row.blind_trips,
                100.0 * row.trips as f64 / row.blind_trips.max(1) as f64,
                row.closest,
                row.blind_met,
                row.seeds,
                100.0 * row.waiting,
                row.detours,
                row.stalled,
                row.us_per_event,
                100.0 * row.reference_trips as f64 / row.reference_blind.max(1) as f64,
            );
            rows.push(row);
        }
    }
    Ok(rows)
}

fn one(name: &str, vertices: usize, layout: &Arc<Layout>, space: &GraphSpace, n: usize, seed: u64, lanes: Lanes) -> anyhow::Result<Row> {
    let params = mrmm_core::traffic::Params { corridors: lanes.corridors, ..Default::default() };
    let world = World { robots: n, places: Some(vertices as u32), params, release: lanes.release, ..World::default() };
    let mut row = Row {
        map: name.to_string(),
        vertices,
        robots: n,
        seeds: SEEDS,
        blind_trips: 0,
        blind_met: 0,
        trips: 0,
        closest: f64::INFINITY,
        too_close: 0,
        detours: 0,
        blocked: 0,
        stalled: 0,
        waiting: 0.0,
        waited_for: [0.0; 5],
        us_per_event: 0.0,
        reference_trips: 0,
        reference_blind: 0,
    };
    let (mut events, mut took) = (0u64, 0.0);
    for s in seed..seed + SEEDS {
        let blind = sim::run(layout, space, World { controlled: false, ..world }, s).map_err(|v| anyhow!("{name}, blind: {v}"))?;
        row.blind_trips += blind.trips;
        row.blind_met += u64::from(blind.too_close > 0);
        let started = Instant::now();
        let r: Report = sim::run(layout, space, world, s).map_err(|v| anyhow!("{name}: {v}"))?;
        took += started.elapsed().as_secs_f64();
        events += r.events;
        row.trips += r.trips;
        row.closest = row.closest.min(r.closest);
        row.too_close += r.too_close;
        row.detours += r.detours;
        row.blocked += r.blocked;
        row.stalled += r.stalled;
        let robot_s = n as f64 * world.duration;
        row.waiting += r.waited / robot_s;
        // Once more counting what the robots waited for, outside the timed run (the same run).
        let counted = sim::run(layout, space, World { causes: true, ..world }, s).map_err(|v| anyhow!("{name}: {v}"))?;
        anyhow::ensure!(counted.trips == r.trips, "{name} seed {s}: the run counting waits drove {} trips, not {}", counted.trips, r.trips);
        let w = counted.waited_for;
        for (into, s) in row.waited_for.iter_mut().zip([w.parked, w.queued, w.oncoming, w.ahead, w.other]) {
            *into += s / robot_s;
        }
    }
    row.waiting /= SEEDS as f64;
    for w in &mut row.waited_for {
        *w /= SEEDS as f64;
    }
    // The whole controlled run, robots' motion included, per event: an upper bound.
    row.us_per_event = took * 1e6 / events.max(1) as f64;
    Ok(row)
}

/// The lifelong PIBT reference on the same map, robots and seeds.
fn reference(row: &mut Row, graph: &mrmm_maps::NavGraph, seed: u64) -> anyhow::Result<()> {
    let world = World { robots: row.robots, places: Some(graph.vertices.len() as u32), ..World::default() };
    for s in seed..seed + SEEDS {
        let r = mrmm_sim::traffic::pibt::run(graph, &world, CLEARANCE, s).map_err(|e| anyhow!("{}, PIBT reference, seed {s}: {e}", row.map))?;
        row.reference_trips += r.trips;
        row.reference_blind += r.blind_trips;
    }
    Ok(())
}

/// Writes the CSV and the summary; `lanes`: how the run held them.
pub fn write(out: &Path, rows: &[Row], command: &str, elapsed: f64, lanes: Lanes) -> anyhow::Result<()> {
    std::fs::write(out.join("results-traffic.csv"), csv(rows))?;
    std::fs::write(out.join("summary-traffic.md"), summary(rows, command, elapsed, lanes))?;
    Ok(())
}

fn csv(rows: &[Row]) -> String {
    let mut csv =
        String::from("map,vertices,robots,seeds,blind_trips,blind_runs_met,trips,closest_m,too_close,steps_aside,blocked,stalled,waiting_share,us_per_event,pibt_trips,pibt_blind_trips,waiting_parked,waiting_queued,waiting_oncoming,waiting_ahead,waiting_other\n");
    for r in rows {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{:.3},{},{},{},{},{:.4},{:.2},{},{},{:.4},{:.4},{:.4},{:.4},{:.4}\n",
            r.map,
            r.vertices,
            r.robots,
            r.seeds,
            r.blind_trips,
            r.blind_met,
            r.trips,
            r.closest,
            r.too_close,
            r.detours,
            r.blocked,
            r.stalled,
            r.waiting,
            r.us_per_event,
            r.reference_trips,
            r.reference_blind,
            r.waited_for[0],
            r.waited_for[1],
            r.waited_for[2],
            r.waited_for[3],
            r.waited_for[4]
        ));
    }
    csv
}

fn summary(rows: &[Row], command: &str, elapsed: f64, how: Lanes) -> String {
    let segment = how.segment;
    let lanes = if segment > 0.0 { format!("lanes longer than {segment} m cut into segments") } else { "every lane one resource".to_string() };
    let locks = match (how.corridors, how.release) {
        (false, false) => "",
        (true, false) => ", corridors locked by direction",
        (false, true) => ", the vertex behind a robot let go once it is clear of it",
        (true, true) => ", corridors locked by direction, the vertex behind a robot let go once it is clear of it",
    };
    let side = mrmm_core::traffic::layout::SIDE_SEGMENT_M;
    let passing = if how.floor {
        format!(", two-way lanes passing where the map's floor plan has room for two robots side by side (a side each way, cut at {side} m; the office has no floor plan)")
    } else if how.passing > 0.0 {
        format!(", two-way lanes of {} m or more passing (a side each way, cut at {side} m)", how.passing)
    } else {
        String::new()
    };
    let mut s = format!(
        "# Traffic on real floor plans\n\n`{command}` ({elapsed:.0} s; {lanes}{locks}{passing}). Each line: {SEEDS} seeds of 600 simulated seconds; robots at 0.5 – 1.5 m/s \
         drive shortest routes to random vertices no other robot is going to, dwell up to 3 s and go on. *Blind*: the same robots \
         without traffic. *Stalled*: a robot stood five minutes wanting to drive. µs/event: the whole controlled run's wall time \
         (robots' motion included) per event traffic handled. *PIBT*: lifelong PIBT, the reference (`mrmm_sim::traffic::pibt`), on the \
         map cut into clearance-sized moves in lockstep, its goals reached against the same discrete robots driving blindly.\n\n\
         | map | vertices | robots | trips (blind) | kept | PIBT keeps | closest, m | blind runs meeting | waiting | steps aside | stalled | µs/event |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} ({}) | {:.0} % | {:.0} % | {:.2} | {} of {} | {:.0} % | {} | {} | {:.1} |\n",
            r.map,
            r.vertices,
            r.robots,
            r.trips,
            r.blind_trips,
            100.0 * r.trips as f64 / r.blind_trips.max(1) as f64,
            100.0 * r.reference_trips as f64 / r.reference_blind.max(1) as f64,
            r.closest,
            r.blind_met,
            r.seeds,
            100.0 * r.waiting,
            r.detours,
            r.stalled,
            r.us_per_event
        ));
    }
    s.push_str(
        "\nWhat the robots stood waiting for, as shares of their time (the first that applies): a robot *parked* at the end of \
         its route; robots that stand waiting themselves (*queued*: a queue, or a gridlock); a robot whose way runs through \
         where the waiting one stands (*oncoming*); one whose way runs through its next vertex (*ahead* of it the same way, or \
         crossing there); anything else.\n\n\
         | map | robots | waiting | parked | queued | oncoming | ahead | other |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let [parked, queued, oncoming, ahead, other] = r.waited_for.map(|w| 100.0 * w);
        s.push_str(&format!(
            "| {} | {} | {:.0} % | {parked:.0} % | {queued:.0} % | {oncoming:.0} % | {ahead:.0} % | {other:.0} % |\n",
            r.map,
            r.robots,
            100.0 * r.waiting
        ));
    }
    s
}
