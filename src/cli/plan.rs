//! `mrmm plan`: a recipe plus robots into per-robot plans (JSON, as sent to robots).

use std::path::Path;

use anyhow::{anyhow, Context};
use mrmm_planner::recipe;
use mrmm_proto::plan::RobotSpec;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Recipe file, or the name of a recipe of the bank (patrol, coverage).
    recipe: String,
    /// JSON file: [{"id", "type", "x", "y", "speed"}, …]; a robot's "reach_m" (metres its battery takes it) keeps it from legs longer than that, and one that fits none is listed in "held".
    #[arg(long)]
    robots: std::path::PathBuf,
    /// Override a recipe parameter (repeatable): key=value; waypoints and region take JSON
    /// (waypoints=all: every vertex of a graph map).
    #[arg(long = "param")]
    params: Vec<String>,
    /// Plan on this map (a Nav2 map's YAML, a patrolling_sim .graph, an Open-RMF navigation
    /// graph): `tour` is then the closed route along its corridors or edges, `length` its length.
    #[arg(long)]
    map: Option<std::path::PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let (origin, text) = match recipe::bank(&args.recipe) {
        Some(xml) if !Path::new(&args.recipe).exists() => (format!("recipe {}", args.recipe), xml.to_string()),
        _ => (args.recipe.clone(), std::fs::read_to_string(&args.recipe).with_context(|| format!("cannot read {} (bank: patrol, coverage)", args.recipe))?),
    };
    let r = recipe::parse(&text).map_err(|e| anyhow!("{origin}: {e}"))?;
    recipe::validate(&r).map_err(|e| anyhow!("{origin}: {e}"))?;
    let robots_text = std::fs::read_to_string(&args.robots).with_context(|| format!("cannot read {}", args.robots.display()))?;
    let robots: Vec<RobotSpec> = serde_json::from_str(&robots_text)
        .with_context(|| format!("{}: expected [{{\"id\", \"type\", \"x\", \"y\", \"speed\"}}, …]", args.robots.display()))?;
    let overrides = recipe::parse_overrides(&args.params)?;
    let map = match &args.map {
        Some(path) => Some(super::map::bundle(path)?.load().map_err(|e| anyhow!("{e}"))?.1),
        None => None,
    };
    let plan = recipe::build_on(&r, &overrides, &robots, map.as_ref()).map_err(|e| anyhow!("{origin}: {e}"))?;
    println!("{}", serde_json::to_string_pretty(&plan)?);
    Ok(())
}
