//! mrmm's research harness, run by `mrmm experiment`: the paper's evaluation on the real system —
//! real `mrmm` processes with time-scaled simulated bodies — one command per figure, written to a
//! directory as `results.csv`, one PNG per experiment and `summary.md`; and the patrolling,
//! traffic and energy benchmarks, simulated in this process.
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

mod comm_loss;
mod energy;
mod fleet;
mod maps;
mod plot;
mod report;
mod run;
mod traffic;
mod wire;

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{anyhow, bail};
use mrmm_proto::BarrierMode;

use run::{Row, Spec};

/// A barrier mode on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Barrier {
    /// Every member tells every other (mrmm's default).
    Mesh,
    /// The paper's: members tell a leader, the leader tells all.
    Leader,
}

impl Barrier {
    fn mode(self) -> BarrierMode {
        match self {
            Barrier::Mesh => BarrierMode::Mesh,
            Barrier::Leader => BarrierMode::Leader,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Kind {
    /// Messages over a run, eventless and with robots extracted after the first round (Fig. 4).
    Messages,
    /// Idleness as the team grows, beside the bound L/(n·v) (Fig. 5).
    Idleness,
    /// Idleness of two team sizes as the environment grows (Fig. 6).
    Environment,
    /// The paper's communication-loss run: central and a robot killed and back, over time.
    CommLoss,
    /// All four.
    All,
    /// Barrier messages per robot of one team against the same robots in four teams of their own
    /// (the team hierarchy; not part of `all`).
    Teams,
    /// The patrolling benchmark: every vertex of patrolling_sim's maps, 1 to 12 robots, idleness
    /// against L*/(n·v) (simulated time, no fleet; not part of `all`).
    Maps,
    /// Robots sharing the corridors of the same floor plans and Open-RMF's office under traffic
    /// and blind: trips, closest approach, waits, gridlocks (simulated time, no fleet; not part
    /// of `all`).
    Traffic,
    /// A patrol's working day on batteries: no charging, naive charging and mrmm's charging
    /// policy with spares against no batteries at all (simulated time, no fleet; not part of
    /// `all`).
    Energy,
}

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which experiment.
    #[arg(value_enum)]
    kind: Kind,
    /// Where results.csv, the figures and summary.md go (created; runs' logs under logs/).
    #[arg(long, default_value = "results")]
    out: PathBuf,
    /// Team sizes (default per experiment: messages 5,10,15,20 — eventless for all but the largest,
    /// extraction for those above --extract; idleness 5,10,15,20,30,40,50; environment 15,20;
    /// comm-loss 5, the largest given).
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..=200))]
    sizes: Option<Vec<u32>>,
    /// traffic: cut lanes longer than this many metres into segments (robots follow one another
    /// a segment apart; default: as the fleet's authority does); 0: every lane is one resource.
    #[arg(long, default_value_t = mrmm_core::traffic::authority::SEGMENT_M)]
    segment: f64,
    /// traffic: hold each corridor (a chain of lanes without a junction) for one direction at a
    /// time.
    #[arg(long)]
    corridors: bool,
    /// traffic: robots hold the vertex behind them until they reach the next (the fleet's robots
    /// report as they are clear of it, and it is let go: this is for comparison).
    #[arg(long)]
    hold_behind: bool,
    /// traffic: mark every lane that runs both ways and is at least this many metres long
    /// passing (wide enough for two robots side by side: a side each way); 0: as drawn.
    #[arg(long, default_value_t = 0.0)]
    passing: f64,
    /// traffic: mark a map's two-way lanes passing where its floor plan (shipped for
    /// patrolling_sim's maps) has room for two robots side by side, instead of by length.
    #[arg(long, conflicts_with = "passing")]
    passing_floor: bool,
    /// Rounds of the patrol per run (default: messages 5, idleness 3, environment 2).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1000))]
    rounds: Option<u32>,
    /// Simulated seconds per wall second for every robot.
    #[arg(long, default_value_t = 10.0)]
    time_scale: f64,
    /// Seed of what is chosen at random (which robots are extracted).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Robots moved to a coverage mission after the first round in the messages experiment.
    #[arg(long, default_value_t = 5)]
    extract: u32,
    /// Environment scales of the environment experiment.
    #[arg(long, value_delimiter = ',', default_values_t = vec![1.0, 2.5, 5.0, 10.0])]
    scales: Vec<f64>,
    /// Barrier modes: the messages and idleness experiments run each; the environment and
    /// time-scale runs the first.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = vec![Barrier::Mesh, Barrier::Leader])]
    barrier: Vec<Barrier>,
    /// The maps experiment: the robots' turn rate, rad/s (the bound L*/(n·v) assumes turns take no
    /// time; a real robot's do).
    #[arg(long, default_value_t = maps::TURN)]
    turn_rate: f64,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Messages => "messages",
            Kind::Idleness => "idleness",
            Kind::Environment => "environment",
            Kind::CommLoss => "comm-loss",
            Kind::All => "all",
            Kind::Maps => "maps",
            Kind::Teams => "teams",
            Kind::Traffic => "traffic",
            Kind::Energy => "energy",
        }
    }
}

/// The runs of one experiment.
fn plan(kind: Kind, a: &Args) -> anyhow::Result<Vec<Spec>> {
    let sizes = |default: &[u32]| -> Vec<usize> { a.sizes.as_deref().unwrap_or(default).iter().map(|&n| n as usize).collect() };
    let modes: Vec<BarrierMode> = a.barrier.iter().map(|b| b.mode()).collect();
    let first = modes.first().copied().unwrap_or_default();
    let spec = |experiment, robots, extract, env_scale, rounds| Spec {
        experiment,
        robots,
        extract,
        env_scale,
        rounds,
        time_scale: a.time_scale,
        seed: a.seed,
        barrier: first,
        teams: 1,
    };
    // Every run of `runs` once per barrier mode, mode by mode.
    let per_mode = |runs: Vec<Spec>| -> Vec<Spec> { modes.iter().flat_map(|&barrier| runs.iter().map(move |s| Spec { barrier, ..s.clone() })).collect() };
    Ok(match kind {
        Kind::Messages => {
            let s = sizes(&[5, 10, 15, 20]);
            let largest = s.iter().copied().max().unwrap_or(0);
            let rounds = a.rounds.unwrap_or(5);
            let k = a.extract as usize;
            let eventless = s.iter().filter(|&&n| n < largest || s.len() == 1).map(|&n| spec("messages", n, 0, 1.0, rounds));
            let extraction = s.iter().filter(|&&n| k > 0 && n > k).map(|&n| spec("messages", n, k, 1.0, rounds.max(2)));
            per_mode(eventless.chain(extraction).collect())
        }
        Kind::Idleness => {
            let s = sizes(&[5, 10, 15, 20, 30, 40, 50]);
            let rounds = a.rounds.unwrap_or(3);
            let mut v: Vec<Spec> = per_mode(s.iter().map(|&n| spec("idleness", n, 0, 1.0, rounds)).collect());
            // Time scaling checked: one size (10, or the smallest asked for) again at a quarter
            // of the time scale, on a fleet of its own.
            if let Some(n) = if s.contains(&10) { Some(10) } else { s.iter().copied().min() } {
                v.push(Spec { time_scale: a.time_scale / 4.0, ..spec("timescale", n, 0, 1.0, rounds) });
            }
            v
        }
        Kind::Environment => {
            let mut v = Vec::new();
            for &scale in &a.scales {
                if !(scale.is_finite() && (0.1..=100.0).contains(&scale)) {
                    bail!("--scales: each scale must be between 0.1 and 100 (got {scale})");
                }
                for n in sizes(&[15, 20]) {
                    v.push(spec("environment", n, 0, scale, a.rounds.unwrap_or(2)));
                }
            }
            v
        }
        Kind::CommLoss => {
            let n = sizes(&[5]).into_iter().max().unwrap_or(5);
            if n < 3 {
                bail!("--sizes: comm-loss needs at least 3 robots (a chain of 3 and one to lose)");
            }
            vec![spec("comm-loss", n, 0, 1.0, 1)]
        }
        Kind::Teams => {
            let mut v = Vec::new();
            for n in sizes(&[20]) {
                if n < 8 || n % 4 != 0 {
                    bail!("--sizes: the teams experiment splits the robots into four equal teams: give multiples of 4 from 8 (got {n})");
                }
                let rounds = a.rounds.unwrap_or(3);
                v.push(spec("teams", n, 0, 1.0, rounds));
                v.push(Spec { teams: 4, ..spec("teams", n, 0, 1.0, rounds) });
            }
            v
        }
        Kind::All | Kind::Maps | Kind::Traffic | Kind::Energy => bail!("internal: `{}` is not a fleet experiment", kind.name()),
    })
}

pub async fn run(a: Args) -> anyhow::Result<()> {
    if a.barrier.is_empty() {
        bail!("--barrier: name at least one of mesh, leader");
    }
    if !(a.time_scale.is_finite() && a.time_scale > 0.0 && a.time_scale <= 1000.0) {
        bail!("--time-scale: must be a number in (0, 1000] (got {})", a.time_scale);
    }
    if a.kind == Kind::Maps {
        return run_maps(&a);
    }
    if a.kind == Kind::Energy {
        return run_energy(&a);
    }
    if a.kind == Kind::Traffic {
        let sizes: Vec<usize> = a.sizes.as_deref().map_or_else(|| traffic::SIZES.to_vec(), |s| s.iter().map(|&n| n as usize).collect());
        let started = std::time::Instant::now();
        if !(a.segment.is_finite() && (a.segment == 0.0 || a.segment >= 0.7)) {
            bail!("--segment: 0 (lanes whole) or a length of at least 0.7 m (got {})", a.segment);
        }
        if !(a.passing.is_finite() && a.passing >= 0.0) {
            bail!("--passing: 0 (lanes as drawn) or a length in metres (got {})", a.passing);
        }
        let lanes = traffic::Lanes { segment: a.segment, corridors: a.corridors, release: !a.hold_behind, passing: a.passing, floor: a.passing_floor };
        let rows = traffic::run(&a.out, &sizes, a.seed, lanes)?;
        traffic::write(&a.out, &rows, &command_line(&a), started.elapsed().as_secs_f64(), lanes)?;
        println!("results in {}: results-traffic.csv, summary-traffic.md", a.out.display());
        return Ok(());
    }
    let kinds = if a.kind == Kind::All { vec![Kind::Messages, Kind::Idleness, Kind::Environment, Kind::CommLoss] } else { vec![a.kind] };
    let mut plans = Vec::new();
    for k in &kinds {
        plans.push((*k, plan(*k, &a)?));
    }
    std::fs::create_dir_all(&a.out).map_err(|e| anyhow!("cannot create {}: {e}", a.out.display()))?;
    let command = command_line(&a);
    let mut rows: Vec<Row> = Vec::new();
    let mut figures = Vec::new();
    let mut runs = 0usize;
    for (kind, specs) in plans {
        let bar = progress(specs.len(), kind.name());
        // One fleet per time scale (a robot's clock is set by its config).
        let mut scales: Vec<f64> = Vec::new();
        for s in &specs {
            if !scales.contains(&s.time_scale) {
                scales.push(s.time_scale);
            }
        }
        for scale in scales {
            let group: Vec<&Spec> = specs.iter().filter(|s| s.time_scale == scale).collect();
            let mut done = Done { rows: &mut rows, figures: &mut figures, runs: &mut runs };
            if let Err(e) = run_group(&a, kind, scale, &group, &bar, &mut done).await {
                bar.finish_and_clear();
                // What ran is still written: a failed run should not cost the others.
                write(&a, &command, &rows, &figures)?;
                return Err(e);
            }
        }
        bar.finish_and_clear();
        let these: Vec<&Row> = rows.iter().filter(|r| r.spec.experiment == kind.name()).collect();
        figures.extend(report::figures(&a.out, kind.name(), &these)?);
        println!("{}: {} runs done", kind.name(), these.len());
    }
    write(&a, &command, &rows, &figures)?;
    println!("results in {}: results.csv, summary.md, {}", a.out.display(), figures.join(", "));
    Ok(())
}

/// `mrmm experiment maps`: the patrolling benchmark, simulated in this process.
fn run_maps(a: &Args) -> anyhow::Result<()> {
    let sizes: Vec<usize> = a.sizes.as_deref().map_or_else(|| maps::SIZES.to_vec(), |s| s.iter().map(|&n| n as usize).collect());
    let started = std::time::Instant::now();
    if !(a.turn_rate.is_finite() && a.turn_rate > 0.0) {
        bail!("--turn-rate: must be a positive number of rad/s (got {})", a.turn_rate);
    }
    let rows = maps::run(&a.out, &sizes, a.seed, a.turn_rate)?;
    let figures = maps::write(&a.out, &rows, &command_line(a), started.elapsed().as_secs_f64(), a.turn_rate)?;
    println!("results in {}: results-maps.csv, summary-maps.md, {}", a.out.display(), figures.join(", "));
    Ok(())
}

/// `mrmm experiment energy`: a patrol's day on batteries, simulated in this process.
fn run_energy(a: &Args) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let day = energy::Day { seed: a.seed, ..energy::Day::default() };
    let runs = energy::run(&day)?;
    energy::write(&a.out, &day, &runs, &command_line(a), started.elapsed().as_secs_f64())?;
    println!("results in {}: results-energy.csv, energy.png, summary-energy.md", a.out.display());
    Ok(())
}

/// What the runs so far produced.
struct Done<'a> {
    rows: &'a mut Vec<Row>,
    figures: &'a mut Vec<String>,
    runs: &'a mut usize,
}

/// The runs of one experiment at one time scale, on one fleet started for them (as many robots
/// as the largest run needs) and stopped after them.
async fn run_group(a: &Args, kind: Kind, scale: f64, group: &[&Spec], bar: &indicatif::ProgressBar, done: &mut Done<'_>) -> anyhow::Result<()> {
    let n = group.iter().map(|s| s.robots).max().unwrap_or(0);
    bar.set_message(format!("starting {n} robots (time scale {scale})"));
    let mut fleet = fleet::Fleet::start(&a.out.join("logs").join(format!("{}-x{scale}", kind.name())), n, scale).await?;
    let mut failed = None;
    for spec in group {
        bar.set_message(format!(
            "{} run {} ({} robots, {} barrier, ×{} environment, {} rounds)",
            spec.experiment,
            spec.label(),
            spec.robots,
            spec.barrier.as_str(),
            spec.env_scale,
            spec.rounds
        ));
        *done.runs += 1;
        let name = format!("{}-{}", spec.experiment, done.runs);
        let result = if kind == Kind::CommLoss {
            comm_loss::run(&mut fleet, &name, spec).await.and_then(|(row, timeline)| {
                done.figures.extend(report::timeline(&a.out, &timeline)?);
                Ok(row)
            })
        } else {
            run::run(&fleet, &name, spec).await
        };
        match result {
            Ok(row) => done.rows.push(row),
            Err(e) => {
                failed = Some(e);
                break;
            }
        }
        bar.inc(1);
    }
    let logs = fleet.dir.clone();
    fleet.stop().await;
    match failed {
        Some(e) => Err(e.context(format!("{} experiment failed (logs in {})", kind.name(), logs.display()))),
        None => Ok(()),
    }
}

/// The command that reproduces this run, every setting spelled out.
fn command_line(a: &Args) -> String {
    let list = |v: &[String]| v.join(",");
    if a.kind == Kind::Traffic {
        let mut c = format!("mrmm experiment traffic --out {} --seed {}", a.out.display(), a.seed);
        if let Some(s) = &a.sizes {
            c.push_str(&format!(" --sizes {}", list(&s.iter().map(u32::to_string).collect::<Vec<_>>())));
        }
        for (on, flag) in [(a.corridors, " --corridors"), (a.hold_behind, " --hold-behind")] {
            if on {
                c.push_str(flag);
            }
        }
        if a.passing > 0.0 {
            c.push_str(&format!(" --passing {}", a.passing));
        }
        if a.passing_floor {
            c.push_str(" --passing-floor");
        }
        return c;
    }
    if a.kind == Kind::Energy {
        return format!("mrmm experiment energy --out {} --seed {}", a.out.display(), a.seed);
    }
    if a.kind == Kind::Maps {
        let mut c = format!("mrmm experiment maps --out {} --seed {} --turn-rate {}", a.out.display(), a.seed, a.turn_rate);
        if let Some(s) = &a.sizes {
            c.push_str(&format!(" --sizes {}", list(&s.iter().map(u32::to_string).collect::<Vec<_>>())));
        }
        return c;
    }
    let mut c = format!("mrmm experiment {} --out {} --time-scale {} --seed {} --extract {}", a.kind.name(), a.out.display(), a.time_scale, a.seed, a.extract);
    if let Some(s) = &a.sizes {
        c.push_str(&format!(" --sizes {}", list(&s.iter().map(u32::to_string).collect::<Vec<_>>())));
    }
    if let Some(r) = a.rounds {
        c.push_str(&format!(" --rounds {r}"));
    }
    c.push_str(&format!(" --scales {}", list(&a.scales.iter().map(f64::to_string).collect::<Vec<_>>())));
    c.push_str(&format!(" --barrier {}", list(&a.barrier.iter().map(|b| b.mode().as_str().to_string()).collect::<Vec<_>>())));
    c
}

fn write(a: &Args, command: &str, rows: &[Row], figures: &[String]) -> anyhow::Result<()> {
    report::csv(&a.out.join("results.csv"), rows)?;
    report::summary(&a.out.join("summary.md"), command, rows, figures)
}

fn progress(n: usize, what: &str) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(n as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template("{prefix:>12} [{bar:30}] {pos}/{len} {elapsed} {msg}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_prefix(what.to_string());
    bar.enable_steady_tick(Duration::from_millis(500));
    bar
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Cli {
        #[command(subcommand)]
        cmd: Sub,
    }

    #[derive(Debug, clap::Subcommand)]
    enum Sub {
        Experiment(super::Args),
    }

    fn parse(line: &str) -> super::Args {
        let Sub::Experiment(a) = Cli::try_parse_from(line.split_whitespace()).expect("parses").cmd;
        a
    }

    #[test]
    fn the_written_command_reproduces_the_run() {
        let a = parse("mrmm experiment idleness --sizes 2,4 --rounds 2 --time-scale 5 --out /tmp/x");
        let line = super::command_line(&a);
        assert_eq!(
            line,
            "mrmm experiment idleness --out /tmp/x --time-scale 5 --seed 1 --extract 5 --sizes 2,4 --rounds 2 --scales 1,2.5,5,10 --barrier mesh,leader"
        );
        assert_eq!(super::command_line(&parse(&line)), line);
    }

    #[test]
    fn plans_follow_the_paper() {
        let a = parse("mrmm experiment all");
        let m = super::plan(super::Kind::Messages, &a).expect("plan");
        let labels = ["5", "10", "15", "10→5", "15→10", "20→15"];
        assert_eq!(m.iter().map(|s| s.label()).collect::<Vec<_>>(), [labels, labels].concat(), "once per barrier");
        assert!(m[..6].iter().all(|s| s.barrier == super::BarrierMode::Mesh) && m[6..].iter().all(|s| s.barrier == super::BarrierMode::Leader));
        let i = super::plan(super::Kind::Idleness, &a).expect("plan");
        assert_eq!(i.len(), 15);
        assert_eq!(i.last().map(|s| (s.experiment, s.robots, s.time_scale, s.barrier)), Some(("timescale", 10, 2.5, super::BarrierMode::Mesh)));
        let e = super::plan(super::Kind::Environment, &parse("mrmm experiment environment --barrier leader")).expect("plan");
        assert!(e.iter().all(|s| s.barrier == super::BarrierMode::Leader));
        assert!(super::plan(super::Kind::Environment, &parse("mrmm experiment environment --scales 0")).is_err());
    }
}
