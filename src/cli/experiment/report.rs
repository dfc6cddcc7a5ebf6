//! The experiments' outputs: `results.csv` (one row per run), one figure per experiment and
//! `summary.md` (setup, machine, numbers, and the paper's claims checked against them).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;

use super::plot::{self, Bars, Group};
use super::run::Row;

const HEADER: &str = "experiment,label,robots,robots_after,extracted,env_scale,rounds,time_scale,seed,tour_m,sync_per_round,wall_s,avg_idleness_s,worst_idleness_s,bound_s,sync_points,sync_wait_per_round_s,msgs_plan,msgs_sync,msgs_total";

pub fn csv(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut out = String::from(HEADER);
    out.push('\n');
    for r in rows {
        let s = &r.spec;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{:.2},{},{:.1},{:.3},{:.3},{:.3},{},{:.3},{},{},{}",
            s.experiment,
            s.label(),
            s.robots,
            r.robots_after,
            s.extract,
            s.env_scale,
            s.rounds,
            s.time_scale,
            s.seed,
            r.tour_m,
            r.sync_per_round,
            r.wall_s,
            r.avg_idleness_s,
            r.worst_idleness_s,
            r.bound_s,
            r.sync_points,
            r.sync_wait_per_round_s,
            r.msgs_plan,
            r.msgs_sync,
            r.msgs_total()
        );
    }
    std::fs::write(path, out).with_context(|| format!("cannot write {}", path.display()))
}

/// Draws the figure of `experiment` from its rows into `dir`; returns the file name.
pub fn figure(dir: &Path, experiment: &str, rows: &[&Row]) -> anyhow::Result<Option<String>> {
    if rows.is_empty() {
        return Ok(None);
    }
    let file = format!("{experiment}.png");
    let path = dir.join(&file);
    match experiment {
        "messages" => plot::bars(
            &path,
            &Bars {
                title: "Messages over a run (paper's Fig. 4)",
                y_label: "messages published",
                x_label: "robots (a→b: a−b moved to a coverage after round 1)",
                series: &["plans", "sync arrivals"],
                groups: rows
                    .iter()
                    .map(|r| Group { label: r.spec.label(), values: vec![r.msgs_plan as f64, r.msgs_sync as f64], note: Some(r.msgs_total().to_string()) })
                    .collect(),
                lines: vec![],
            },
        )?,
        "idleness" => plot::bars(
            &path,
            &Bars {
                title: "Average idleness as robots grow (paper's Fig. 5)",
                y_label: "idleness, robot seconds",
                x_label: "robots (above the bars: barrier wait per robot per round)",
                series: &["measured"],
                groups: rows
                    .iter()
                    .map(|r| Group { label: r.spec.label(), values: vec![r.avg_idleness_s], note: Some(format!("sync {:.1} s", r.sync_wait_per_round_s)) })
                    .collect(),
                lines: vec![("bound L/(n·v)", rows.iter().map(|r| r.bound_s).collect())],
            },
        )?,
        "environment" => {
            // One group per scale, one bar per team size; idleness divided by the scale so that
            // the groups share an axis.
            let mut sizes: Vec<usize> = rows.iter().map(|r| r.spec.robots).collect();
            sizes.sort_unstable();
            sizes.dedup();
            let mut scales: Vec<f64> = rows.iter().map(|r| r.spec.env_scale).collect();
            scales.sort_by(f64::total_cmp);
            scales.dedup();
            let names: Vec<String> = sizes.iter().map(|n| format!("{n} robots")).collect();
            let series: Vec<&str> = names.iter().map(String::as_str).collect();
            let find = |n: usize, s: f64| rows.iter().find(|r| r.spec.robots == n && r.spec.env_scale == s);
            let groups = scales
                .iter()
                .map(|&s| Group {
                    label: format!("×{s}"),
                    values: sizes.iter().map(|&n| find(n, s).map_or(f64::NAN, |r| r.avg_idleness_s / s)).collect(),
                    note: None,
                })
                .collect();
            plot::bars(
                &path,
                &Bars {
                    title: "Idleness in larger environments (paper's Fig. 6)",
                    y_label: "idleness ÷ environment scale, robot seconds",
                    x_label: "environment scale",
                    series: &series,
                    groups,
                    lines: vec![],
                },
            )?
        }
        _ => return Ok(None),
    }
    Ok(Some(file))
}

/// The machine, for the summary.
fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| t.lines().find(|l| l.starts_with("model name")).and_then(|l| l.split(':').nth(1)).map(|s| s.trim().to_string()))
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| t.lines().next().and_then(|l| l.split_whitespace().nth(1)).and_then(|k| k.parse::<f64>().ok()))
        .map_or("?".into(), |kb| format!("{:.0} GiB", kb / 1024.0 / 1024.0));
    format!("{cpu}, {cores} cores, {mem} memory, Linux")
}

/// `summary.md`: what ran, the numbers, and the paper's claims checked.
pub fn summary(path: &Path, command: &str, rows: &[Row], figures: &[String]) -> anyhow::Result<()> {
    let mut out = String::from("# mrmm experiment: the paper's evaluation on the real system\n\n");
    let _ = writeln!(out, "Command: `{command}`  \nMachine: {}  \n", machine());
    out.push_str(
        "Setup: central and identical simulated ground robots (1 m/s) as real `mrmm` processes on loopback (plain TCP), \
         a circular patrol of eight waypoints (tour ≈ 50 m at scale 1) planned by the patrol planner with its default sync \
         spacing, mesh barrier. Times are robot seconds (wall × time scale). Messages are publications by mrmm's code \
         (plans sent by the mission manager, barrier arrivals by the robots), as the mission reports them; the barrier wait \
         is counted after the formation (the first barrier gathers the team at its slots); deliveries on \
         the wire are not counted yet.\n\n",
    );
    for f in figures {
        let _ = writeln!(out, "![{f}]({f})\n");
    }
    out.push_str(
        "| experiment | run | robots after | env × | rounds | idleness s | bound s | sync wait s/round | sync points | messages (plan + sync) | wall s |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.spec;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} ({} + {}) | {:.0} |",
            s.experiment,
            s.label(),
            r.robots_after,
            s.env_scale,
            s.rounds,
            r.avg_idleness_s,
            r.bound_s,
            r.sync_wait_per_round_s,
            r.sync_points,
            r.msgs_total(),
            r.msgs_plan,
            r.msgs_sync,
            r.wall_s
        );
    }
    out.push_str("\n## The paper's claims, checked against this run\n\n");
    for line in claims(rows) {
        let _ = writeln!(out, "- {line}");
    }
    std::fs::write(path, out).with_context(|| format!("cannot write {}", path.display()))
}

fn verdict(ok: bool) -> &'static str {
    if ok {
        "**shown**"
    } else {
        "**not shown**"
    }
}

/// Each of the paper's findings, with whether these rows show it (and the numbers that decide).
pub fn claims(rows: &[Row]) -> Vec<String> {
    let mut out = Vec::new();
    let of = |e: &str, extracted: bool| -> Vec<&Row> { rows.iter().filter(|r| r.spec.experiment == e && (r.spec.extract > 0) == extracted).collect() };
    let eventless = of("messages", false);
    if eventless.len() >= 2 {
        let (a, b) = (eventless[0], eventless[eventless.len() - 1]);
        let grows = eventless.windows(2).all(|w| w[1].msgs_total() > w[0].msgs_total());
        let exp = (b.msgs_total() as f64 / a.msgs_total().max(1) as f64).ln() / (b.spec.robots as f64 / a.spec.robots as f64).ln();
        out.push(format!(
            "Fig. 4 — messages grow faster than the team (polynomially): {} ({} → {} messages from {} to {} robots, growth exponent {exp:.2}).",
            verdict(grows && exp > 1.0),
            a.msgs_total(),
            b.msgs_total(),
            a.spec.robots,
            b.spec.robots
        ));
    }
    for x in of("messages", true) {
        let after = x.spec.robots - x.spec.extract;
        if let Some(e) = eventless.iter().find(|e| e.spec.robots == after) {
            out.push(format!(
                "Fig. 4 — {} robots after an extraction cost slightly fewer messages than {after} from the start: {} ({}: {} vs {after}: {}).",
                after,
                verdict(x.msgs_total() < e.msgs_total()),
                x.spec.label(),
                x.msgs_total(),
                e.msgs_total()
            ));
        }
    }
    let idle = of("idleness", false);
    if idle.len() >= 2 {
        // The paper: idleness falls as robots are added up to 15, then stays.
        let early: Vec<&&Row> = idle.iter().filter(|r| r.spec.robots <= 15).collect();
        let falls = early.len() >= 2 && early.windows(2).all(|w| w[1].avg_idleness_s < w[0].avg_idleness_s);
        out.push(format!(
            "Fig. 5 — idleness decreases as robots are added (up to 15): {} ({}).",
            verdict(falls),
            idle.iter().map(|r| format!("{}: {:.1} s", r.spec.robots, r.avg_idleness_s)).collect::<Vec<_>>().join(", ")
        ));
        // The plateau: the first step where adding robots gains less than half what the bound
        // L/(n·v) promises.
        let gain = |a: &Row, b: &Row| (1.0 - b.avg_idleness_s / a.avg_idleness_s, 1.0 - b.bound_s / a.bound_s);
        let steps: Vec<String> = idle
            .windows(2)
            .map(|w| {
                let (m, b) = gain(w[0], w[1]);
                format!("{}→{}: {:.0} % (bound {:.0} %)", w[0].spec.robots, w[1].spec.robots, m * 100.0, b * 100.0)
            })
            .collect();
        let plateau = idle.windows(2).find(|w| {
            let (m, b) = gain(w[0], w[1]);
            m < 0.5 * b
        });
        out.push(format!(
            "Fig. 5 — a plateau, synchronisation eating the gain of more robots (the paper's starts after 15): {}{} (idleness gained per step: {}; barrier wait per robot per round: {}).",
            verdict(plateau.is_some()),
            plateau.map_or(String::new(), |w| format!(", after {} robots", w[0].spec.robots)),
            steps.join("; "),
            idle.iter().map(|r| format!("{} robots {:.1} s", r.spec.robots, r.sync_wait_per_round_s)).collect::<Vec<_>>().join(", ")
        ));
    }
    let env = of("environment", false);
    let mut sizes: Vec<usize> = env.iter().map(|r| r.spec.robots).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let mut scales: Vec<f64> = env.iter().map(|r| r.spec.env_scale).collect();
    scales.sort_by(f64::total_cmp);
    scales.dedup();
    if let ([first, .., last], [small, .., big]) = (scales.as_slice(), sizes.as_slice()) {
        let at = |n: usize, s: f64| env.iter().find(|r| r.spec.robots == n && r.spec.env_scale == s);
        let share = |r: &Row| r.sync_wait_per_round_s / (r.tour_m / super::fleet::SPEED);
        if let (Some(a0), Some(b0), Some(a1), Some(b1)) = (at(*small, *first), at(*big, *first), at(*small, *last), at(*big, *last)) {
            out.push(format!(
                "Fig. 6 — in a larger environment synchronisation becomes negligible: {} (barrier wait per round / tour time at ×{first}: {:.1} %, at ×{last}: {:.1} %, {big} robots).",
                verdict(share(b1) < share(b0)),
                share(b0) * 100.0,
                share(b1) * 100.0
            ));
            let r0 = b0.avg_idleness_s / a0.avg_idleness_s;
            let r1 = b1.avg_idleness_s / a1.avg_idleness_s;
            out.push(format!(
                "Fig. 6 — the plateau moves to more robots (the larger team gains more when the environment grows): {} (idleness {big} vs {small} robots: ×{r0:.2} at ×{first}, ×{r1:.2} at ×{last}; the bound is ×{:.2}).",
                verdict(r1 < r0),
                *small as f64 / *big as f64
            ));
        }
    }
    for q in of("timescale", false) {
        if let Some(r) = idle.iter().find(|r| r.spec.robots == q.spec.robots) {
            let diff = (q.avg_idleness_s / r.avg_idleness_s - 1.0) * 100.0;
            out.push(format!(
                "Time scaling (ours, not the paper's): {} robots give the same idleness at a time scale of {} as at {}: {} ({:.2} s vs {:.2} s, {diff:+.1} %; within 3 % asked).",
                q.spec.robots,
                r.spec.time_scale,
                q.spec.time_scale,
                verdict(diff.abs() <= 3.0),
                r.avg_idleness_s,
                q.avg_idleness_s
            ));
        }
    }
    if out.is_empty() {
        out.push("Too few runs to check any of the paper's claims (each needs at least two configurations).".into());
    }
    out
}
