//! `mrmm map check FILE`: reads a map as the fleet would and says what it is, or what is wrong;
//! `mrmm map graph FILE --out G.yaml`: derives a navigation graph from a grid map's free space,
//! or marks a graph's lanes passing where its floor plan has room.

use std::path::PathBuf;

use anyhow::{anyhow, Context};
use mrmm_maps::Bundle;

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Read a map (a Nav2 map's YAML, a patrolling_sim .graph, an Open-RMF navigation graph) and
    /// print its format, size, free area or vertices and edges, extent and content hash.
    Check {
        file: PathBuf,
        /// The floor plan a graph map is drawn on (a Nav2 map's YAML in its frame), checked and
        /// read as central reads it (`--floor-plan`): lanes passing where it has room.
        #[arg(long)]
        floor_plan: Option<PathBuf>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Derive a navigation graph from a Nav2 map's free space (lanes both ways along corridors'
    /// middles and through doors) and write it as an Open-RMF navigation graph, for people to
    /// check and edit, and for traffic. Given a navigation graph and its --floor-plan: write it
    /// with its two-way lanes marked passing where the plan has room.
    Graph {
        file: PathBuf,
        /// The floor plan (a Nav2 map's YAML) the graph FILE is drawn on.
        #[arg(long)]
        floor_plan: Option<PathBuf>,
        /// Where the graph goes (Open-RMF nav graph YAML).
        #[arg(long)]
        out: PathBuf,
        /// Robots' radius, m: lanes keep this far from every cell that is not free.
        #[arg(long, default_value_t = mrmm_maps::roadmap::Params::default().radius)]
        radius: f64,
        /// Dead ends shorter than this are dropped, m.
        #[arg(long, default_value_t = mrmm_maps::roadmap::Params::default().prune)]
        prune: f64,
        /// Lanes with room for a robot's centre this far to each side are marked passing (two
        /// robots pass each other on them: `passing: true` among the lane's properties), m; 0:
        /// none. The default is how far to the right of a passing lane traffic lays each way.
        #[arg(long, default_value_t = mrmm_core::traffic::layout::PASSING_OFFSET_M)]
        passing: f64,
        /// The level's name in the file.
        #[arg(long, default_value = "L1")]
        level: String,
    },
}

/// Reads the map at `path` (and the image a Nav2 YAML names) into a bundle.
pub fn bundle(path: &std::path::Path) -> anyhow::Result<Bundle> {
    bundle_on(path, None)
}

/// [`bundle`], a graph map on the floor plan at `plan` if one is given
/// ([`Bundle::collect_on_plan`]).
pub fn bundle_on(path: &std::path::Path, plan: Option<&std::path::Path>) -> anyhow::Result<Bundle> {
    let read = |p: &str| std::fs::read(p).map_err(|e| e.to_string());
    match plan {
        Some(plan) => Bundle::collect_on_plan(&path.to_string_lossy(), &plan.to_string_lossy(), read),
        None => Bundle::collect(&path.to_string_lossy(), read),
    }
    .map_err(|e| anyhow!("{e}"))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Check { file, floor_plan, json } => check(&file, floor_plan.as_deref(), json),
        What::Graph { file, floor_plan, out, radius, prune, passing, level } => {
            let params = mrmm_maps::roadmap::Params { radius, prune, passing, ..Default::default() };
            match floor_plan {
                Some(plan) => graph_on(&file, &plan, &out, &params, &level),
                None => graph(&file, &out, params, &level),
            }
        }
    }
}

fn graph(file: &std::path::Path, out: &std::path::Path, params: mrmm_maps::roadmap::Params, level: &str) -> anyhow::Result<()> {
    let (_, map) = bundle(file)?.load().map_err(|e| anyhow!("{e}"))?;
    let Some(grid) = map.grid() else {
        anyhow::bail!(
            "{}: a navigation graph already; `mrmm map graph` derives one from a grid map (a Nav2 map's YAML), or marks this one's lanes passing given its --floor-plan",
            file.display()
        );
    };
    let g = mrmm_maps::roadmap::derive(&file.to_string_lossy(), grid, &params).map_err(|e| anyhow!("{e}"))?;
    write_graph(file, &g, out, level)
}

/// `mrmm map graph G --floor-plan P --out O`: graph `file` written with its two-way lanes marked
/// passing where the plan at `plan` has room (`params`' radius and passing offset).
fn graph_on(file: &std::path::Path, plan: &std::path::Path, out: &std::path::Path, params: &mrmm_maps::roadmap::Params, level: &str) -> anyhow::Result<()> {
    // Checked as central checks a graph on its plan (every vertex in its free space).
    bundle_on(file, Some(plan))?.load().map_err(|e| anyhow!("{e}"))?;
    let (_, map) = bundle(file)?.load().map_err(|e| anyhow!("{e}"))?;
    let (_, floor) = bundle(plan)?.load().map_err(|e| anyhow!("{e}"))?;
    let (Some(g), Some(grid)) = (map.graph(), floor.grid()) else { anyhow::bail!("{}: give a navigation graph and its floor plan", file.display()) };
    let g = mrmm_maps::roadmap::mark_passing_on(grid, g.clone(), params.radius, params.passing);
    write_graph(file, &g, out, level)
}

/// Writes `g` as an Open-RMF nav graph named after `file` and says what it holds.
fn write_graph(file: &std::path::Path, g: &mrmm_maps::NavGraph, out: &std::path::Path, level: &str) -> anyhow::Result<()> {
    let name = file.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    std::fs::write(out, mrmm_maps::rmf::write(g, &name, level)).with_context(|| format!("cannot write {}", out.display()))?;
    let s = g.summary();
    let junctions = g.vertices.iter().filter(|v| v.name.starts_with("junction")).count();
    let lanes = g.lanes().len();
    let ways = if g.two_way_lanes().len() == lanes { "lanes both ways" } else { "lanes" };
    println!("{}: {} vertices ({junctions} junctions), {lanes} {ways} ({} passing), {:.1} m of lanes", out.display(), s.vertices, s.passing, s.length_m);
    Ok(())
}

fn check(file: &std::path::Path, plan: Option<&std::path::Path>, json: bool) -> anyhow::Result<()> {
    let b = bundle_on(file, plan)?;
    let (format, map) = b.load().map_err(|e| anyhow!("{e}"))?;
    let s = map.summary(format);
    let info = mrmm_core::maps::info(&file.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default(), &b.hash(), b.size() as u64, &s);
    if json {
        println!("{}", serde_json::to_string_pretty(&serde_json::json!({ "summary": s, "hash": info.hash, "bytes": info.bytes }))?);
        return Ok(());
    }
    println!("{}: {} map", file.display(), format.as_str());
    println!("size    {}", info.size);
    if let Some(g) = &s.grid {
        println!("cells   {:.0} m² occupied, {:.0} m² unknown", g.occupied_m2, g.unknown_m2);
    }
    println!("extent  ({:.2}, {:.2}) – ({:.2}, {:.2}) m", s.min.x, s.min.y, s.max.x, s.max.y);
    println!("bytes   {}", info.bytes);
    println!("hash    {}", info.hash);
    Ok(())
}
