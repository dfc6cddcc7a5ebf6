//! `mrmm map check FILE`: reads a map as the fleet would and says what it is, or what is wrong;
//! `mrmm map graph FILE --out G.yaml`: derives a navigation graph from a grid map's free space.

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
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Derive a navigation graph from a Nav2 map's free space (lanes both ways along corridors'
    /// middles and through doors) and write it as an Open-RMF navigation graph, for people to
    /// check and edit, and for traffic.
    Graph {
        file: PathBuf,
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
    Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow!("{e}"))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.what {
        What::Check { file, json } => check(&file, json),
        What::Graph { file, out, radius, prune, passing, level } => {
            graph(&file, &out, mrmm_maps::roadmap::Params { radius, prune, passing, ..Default::default() }, &level)
        }
    }
}

fn graph(file: &std::path::Path, out: &std::path::Path, params: mrmm_maps::roadmap::Params, level: &str) -> anyhow::Result<()> {
    let (_, map) = bundle(file)?.load().map_err(|e| anyhow!("{e}"))?;
    let Some(grid) = map.grid() else {
        anyhow::bail!("{}: a navigation graph already; `mrmm map graph` derives one from a grid map (a Nav2 map's YAML)", file.display());
    };
    let name = file.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    let g = mrmm_maps::roadmap::derive(&file.to_string_lossy(), grid, &params).map_err(|e| anyhow!("{e}"))?;
    std::fs::write(out, mrmm_maps::rmf::write(&g, &name, level)).with_context(|| format!("cannot write {}", out.display()))?;
    let metres: f64 = g.edges.iter().map(|e| e.length).sum::<f64>() / 2.0;
    let junctions = g.vertices.iter().filter(|v| v.name.starts_with("junction")).count();
    let passing = g.edges.iter().filter(|e| e.passing).count() / 2;
    println!(
        "{}: {} vertices ({junctions} junctions), {} lanes both ways ({passing} passing), {metres:.1} m of lanes",
        out.display(),
        g.vertices.len(),
        g.edges.len() / 2
    );
    Ok(())
}

fn check(file: &std::path::Path, json: bool) -> anyhow::Result<()> {
    let b = bundle(file)?;
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
