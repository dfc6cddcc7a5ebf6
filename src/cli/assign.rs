//! `mrmm assign`: optimal assignment of robots (rows) to slots (columns) from a CSV cost matrix.

use std::path::PathBuf;

use anyhow::Context;
use mrmm_planner::assign::{self, Costs};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV file: one row per robot, comma-separated costs, one column per slot.
    file: PathBuf,
    /// Minimise the largest cost (time until the last robot is in place), then the total.
    #[arg(long)]
    bottleneck: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.file).with_context(|| format!("cannot read {}", args.file.display()))?;
    let costs = Costs::parse_csv(&text).with_context(|| args.file.display().to_string())?;
    let a = if args.bottleneck { assign::bottleneck(&costs) } else { assign::min_sum(&costs) };
    println!("cost {}", a.total);
    println!("max {}", a.max);
    for (robot, slot) in a.slot.iter().enumerate() {
        println!("{robot} {slot}");
    }
    Ok(())
}
