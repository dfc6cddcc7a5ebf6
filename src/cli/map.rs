//! `mrmm map check FILE`: reads a map as the fleet would and says what it is, or what is wrong.

use std::path::PathBuf;

use anyhow::anyhow;
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
}

/// Reads the map at `path` (and the image a Nav2 YAML names) into a bundle.
pub fn bundle(path: &std::path::Path) -> anyhow::Result<Bundle> {
    Bundle::collect(&path.to_string_lossy(), |p| std::fs::read(p).map_err(|e| e.to_string())).map_err(|e| anyhow!("{e}"))
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let What::Check { file, json } = args.what;
    let b = bundle(&file)?;
    let (format, map) = b.load().map_err(|e| anyhow!("{e}"))?;
    let s = map.summary(format);
    let info = mrmm_manager::maps::info(&file.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default(), &b.hash(), b.size() as u64, &s);
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
