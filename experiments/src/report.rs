//! The experiments' outputs: `results.csv` (one row per run), one figure per experiment and
//! `summary.md` (setup, machine, numbers, and the paper's claims checked against them).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;

use mrmm_proto::BarrierMode;

use crate::plot::{self, Bars, Group};
use crate::run::Row;

const HEADER: &str = "experiment,label,barrier,robots,robots_after,extracted,env_scale,rounds,time_scale,seed,tour_m,sync_per_round,wall_s,avg_idleness_s,worst_idleness_s,bound_s,sync_points,sync_wait_per_round_s,msgs_plan,msgs_sync,msgs_total,wire_command,wire_barrier,wire_barrier_to_central,wire_telemetry,wire_chain,wire_mission,wire_system,wire_total";

pub fn csv(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut out = String::from(HEADER);
    out.push('\n');
    for r in rows {
        let s = &r.spec;
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{:.2},{},{:.1},{:.3},{:.3},{:.3},{},{:.3},{},{},{},{},{},{},{},{},{},{},{}",
            s.experiment,
            s.label(),
            s.barrier.as_str(),
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
            r.msgs_total(),
            r.wire.get("command"),
            r.wire.barrier(),
            r.wire.barrier() - r.wire.barrier_between_robots(),
            r.wire.get("telemetry"),
            r.wire.get("chain"),
            r.wire.get("mission"),
            r.wire.get("system"),
            r.wire.total()
        );
    }
    std::fs::write(path, out).with_context(|| format!("cannot write {}", path.display()))
}

/// The barrier modes among `rows`, in the order they ran.
fn modes(rows: &[&Row]) -> Vec<BarrierMode> {
    let mut m: Vec<BarrierMode> = Vec::new();
    for r in rows {
        if !m.contains(&r.spec.barrier) {
            m.push(r.spec.barrier);
        }
    }
    m
}

/// One group per configuration label (in run order), one value per barrier mode.
fn by_label(rows: &[&Row], modes: &[BarrierMode], value: impl Fn(&Row) -> f64, note: impl Fn(&[Option<&Row>]) -> Option<String>) -> Vec<Group> {
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        if !labels.contains(&r.spec.label()) {
            labels.push(r.spec.label());
        }
    }
    labels
        .into_iter()
        .map(|label| {
            let of: Vec<Option<&Row>> = modes.iter().map(|m| rows.iter().copied().find(|r| r.spec.label() == label && r.spec.barrier == *m)).collect();
            Group { values: of.iter().map(|r| r.map_or(f64::NAN, &value)).collect(), note: note(&of), label }
        })
        .collect()
}

/// Draws the figures of `experiment` from its rows into `dir`; returns their file names.
pub fn figures(dir: &Path, experiment: &str, rows: &[&Row]) -> anyhow::Result<Vec<String>> {
    if rows.is_empty() {
        return Ok(vec![]);
    }
    let modes = modes(rows);
    let names: Vec<String> = modes.iter().map(|m| format!("{} barrier", m.as_str())).collect();
    let series: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut files = Vec::new();
    let mut draw = |file: &str, bars: Bars| -> anyhow::Result<()> {
        plot::bars(&dir.join(file), &bars)?;
        files.push(file.to_string());
        Ok(())
    };
    let by_mode = ByMode { rows, modes: &modes, series: &series };
    match experiment {
        "messages" => by_mode.messages(&mut draw)?,
        "idleness" => by_mode.idleness(&mut draw)?,
        "environment" => environment(rows, &mut draw)?,
        _ => {}
    }
    Ok(files)
}

/// Draws one figure into a file of the report's directory.
type Draw<'d> = dyn FnMut(&str, Bars) -> anyhow::Result<()> + 'd;

/// Rows grouped by label, a bar per barrier mode.
struct ByMode<'a> {
    rows: &'a [&'a Row],
    modes: &'a [BarrierMode],
    series: &'a [&'a str],
}

impl ByMode<'_> {
    /// The paper's Fig. 4: messages published, and the same on the wire.
    fn messages(&self, draw: &mut Draw) -> anyhow::Result<()> {
        let x_label = "robots (a→b: a−b moved to a coverage after round 1)";
        draw(
            "messages.png",
            Bars {
                title: "Plans and barrier messages published over a run (paper's Fig. 4)",
                y_label: "messages published",
                x_label,
                series: self.series,
                groups: by_label(self.rows, self.modes, |r| r.msgs_total() as f64, |_| None),
                lines: vec![],
            },
        )?;
        draw(
            "messages-wire.png",
            Bars {
                title: "The same messages on the wire (a publication to k nodes is k)",
                y_label: "plan and barrier messages sent on links",
                x_label,
                series: self.series,
                groups: by_label(self.rows, self.modes, |r| (r.wire.get("command") + r.wire.barrier()) as f64, |_| None),
                lines: vec![],
            },
        )
    }

    /// The paper's Fig. 5: average idleness as robots grow, with the bound.
    fn idleness(&self, draw: &mut Draw) -> anyhow::Result<()> {
        // The bound depends on the team only: one line, from whichever mode ran the size.
        let groups = by_label(
            self.rows,
            self.modes,
            |r| r.avg_idleness_s,
            |of| {
                let waits: Vec<String> = of.iter().map(|r| r.map_or("–".into(), |r| format!("{:.1}", r.sync_wait_per_round_s))).collect();
                Some(format!("{} s", waits.join("/")))
            },
        );
        let bound: Vec<f64> = groups.iter().map(|g| self.rows.iter().find(|r| r.spec.label() == g.label).map_or(f64::NAN, |r| r.bound_s)).collect();
        draw(
            "idleness.png",
            Bars {
                title: "Average idleness as robots grow (paper's Fig. 5)",
                y_label: "idleness, robot seconds",
                x_label: &format!(
                    "robots (above the bars: barrier wait per robot per round, {})",
                    self.modes.iter().map(|m| m.as_str()).collect::<Vec<_>>().join("/")
                ),
                series: self.series,
                groups,
                lines: vec![("bound L/(n·v)", bound)],
            },
        )
    }
}

/// The team sizes and environment scales of some runs, each sorted and without repeats.
fn sizes_and_scales(rows: &[&Row]) -> (Vec<usize>, Vec<f64>) {
    let mut sizes: Vec<usize> = rows.iter().map(|r| r.spec.robots).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let mut scales: Vec<f64> = rows.iter().map(|r| r.spec.env_scale).collect();
    scales.sort_by(f64::total_cmp);
    scales.dedup();
    (sizes, scales)
}

/// The paper's Fig. 6: one group per environment scale, one bar per team size; idleness divided
/// by the scale so that the groups share an axis.
fn environment(rows: &[&Row], draw: &mut Draw) -> anyhow::Result<()> {
    let (sizes, scales) = sizes_and_scales(rows);
    let names: Vec<String> = sizes.iter().map(|n| format!("{n} robots")).collect();
    let series: Vec<&str> = names.iter().map(String::as_str).collect();
    let find = |n: usize, s: f64| rows.iter().find(|r| r.spec.robots == n && r.spec.env_scale == s);
    let groups = scales
        .iter()
        .map(|&s| Group { label: format!("×{s}"), values: sizes.iter().map(|&n| find(n, s).map_or(f64::NAN, |r| r.avg_idleness_s / s)).collect(), note: None })
        .collect();
    draw(
        "environment.png",
        Bars {
            title: "Idleness in larger environments (paper's Fig. 6)",
            y_label: "idleness ÷ environment scale, robot seconds",
            x_label: "environment scale",
            series: &series,
            groups,
            lines: vec![],
        },
    )
}

/// The communication-loss run's timeline: `comm-loss-timeline.csv` and `comm-loss.png`;
/// returns the figure's file name.
pub fn timeline(dir: &Path, t: &crate::comm_loss::Timeline) -> anyhow::Result<Vec<String>> {
    let csv = dir.join("comm-loss-timeline.csv");
    std::fs::write(&csv, crate::comm_loss::timeline_csv(t)).with_context(|| format!("cannot write {}", csv.display()))?;
    let series = |f: &dyn Fn(&crate::comm_loss::Point) -> Option<f64>| -> Vec<(f64, f64)> { t.points.iter().filter_map(|p| f(p).map(|v| (p.t, v))).collect() };
    let file = "comm-loss.png".to_string();
    plot::timeline(
        &dir.join(&file),
        &plot::Timeline {
            title: "Communication loss (the paper's section 4.3): the patrol over time",
            x_label: "robot seconds since the mission was created",
            panels: vec![
                ("idleness, robot s", vec![("worst so far", series(&|p| p.worst_idleness)), ("average so far", series(&|p| p.avg_idleness))]),
                ("barriers passed", vec![("by the team, every plan", series(&|p| Some(p.barriers as f64)))]),
            ],
            events: &t.events,
        },
    )?;
    Ok(vec![file])
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
         spacing; the barrier mode of each run is in its row (`mesh`: every member tells every other; `leader`: the paper's, \
         members tell the lowest live id, which tells all). Times are robot seconds (wall × time scale); the barrier wait is \
         counted after the formation (the first barrier gathers the team at its slots). Messages are counted twice: as \
         *published* by mrmm's code (plans sent by the mission manager, barrier arrivals and releases by the robots, as the \
         mission reports them), and as *sent on the wire*: every node counts, in Zenoh's own statistics (`stats` feature, \
         per key expression, read from each node's admin space), the messages it sends on its links — a publication to k \
         other nodes is k messages. Wire kinds: command (plans, orders and their answers), barrier, telemetry, chain \
         (manager replication), mission (controls, status), system (operator API).\n\n",
    );
    for f in figures {
        let _ = writeln!(out, "![{f}]({f})\n");
    }
    out.push_str(
        "| experiment | run | barrier | robots after | env × | rounds | idleness s | bound s | sync wait s/round | sync points | published (plan + sync) | wire: plan, barrier, telemetry, chain, all | wall s |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.spec;
        let w = &r.wire;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} ({} + {}) | {}, {}, {}, {}, {} | {:.0} |",
            s.experiment,
            s.label(),
            s.barrier.as_str(),
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
            w.get("command"),
            w.barrier(),
            w.get("telemetry"),
            w.get("chain"),
            w.total(),
            r.wall_s
        );
    }
    let teams: Vec<&Row> = rows.iter().filter(|r| r.spec.experiment == "teams").collect();
    if !teams.is_empty() {
        out.push_str("\n## Teams: barrier messages per robot\n\nBarrier messages sent between robots on the wire (Zenoh's statistics), per robot and per barrier its team passed:\n\n| robots | teams | barriers passed | barrier messages | per robot per barrier |\n|---|---|---|---|---|\n");
        for r in teams {
            let per = r.wire.barrier_between_robots() as f64 / (r.spec.robots.max(1) as f64 * f64::from(r.sync_points.max(1)));
            let _ = writeln!(out, "| {} | {} | {} | {} | {per:.1} |", r.spec.robots, r.spec.label(), r.sync_points, r.wire.barrier_between_robots());
        }
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

/// Each of the paper's findings, with whether these rows show it (and the numbers that decide),
/// for each barrier mode; then our claims about the two barriers.
pub fn claims(rows: &[Row]) -> Vec<String> {
    let all: Vec<&Row> = rows.iter().collect();
    let modes = modes(&all);
    let mut out = Vec::new();
    for m in &modes {
        let these: Vec<&Row> = all.iter().copied().filter(|r| r.spec.barrier == *m).collect();
        for line in paper_claims(&these) {
            out.push(if modes.len() > 1 { format!("[{} barrier] {line}", m.as_str()) } else { line });
        }
    }
    out.extend(barrier_claims(&all));
    if out.is_empty() {
        out.push("Too few runs to check any of the paper's claims (each needs at least two configurations).".into());
    }
    out
}

/// Ours: the leader barrier costs about 2(n−1) messages on the wire per sync point and one more
/// hop; the mesh barrier n−1 times as many deliveries as publications, n(n−1) per point.
fn barrier_claims(rows: &[&Row]) -> Vec<String> {
    let mut out = Vec::new();
    let eventless = |m: BarrierMode| -> Vec<&Row> {
        rows.iter().copied().filter(|r| r.spec.barrier == m && r.spec.extract == 0 && matches!(r.spec.experiment, "messages" | "idleness")).collect()
    };
    let per_point = |r: &Row| r.wire.barrier_between_robots() as f64 / f64::from(r.sync_points.max(1));
    let to_router = |r: &Row| (r.wire.barrier() - r.wire.barrier_between_robots()) as f64 / f64::from(r.sync_points.max(1));
    for (m, predicted, what) in [
        (BarrierMode::Mesh, (|n: f64| n * (n - 1.0)) as fn(f64) -> f64, "n(n−1)"),
        (BarrierMode::Leader, (|n: f64| 2.0 * (n - 1.0)) as fn(f64) -> f64, "2(n−1)"),
    ] {
        let runs = eventless(m);
        if runs.is_empty() {
            continue;
        }
        let ratios: Vec<f64> = runs.iter().map(|r| per_point(r) / predicted(r.spec.robots as f64).max(1.0)).collect();
        let ok = ratios.iter().all(|q| (0.8..=1.6).contains(q));
        out.push(format!(
            "Barriers (ours) — the {} barrier sends about {what} messages between robots per sync point: {} ({}; measured ÷ predicted within 0.8–1.6 asked; besides, central received {} per point, one per publication, and dropped them).",
            m.as_str(),
            verdict(ok),
            runs.iter().zip(&ratios).map(|(r, q)| format!("{} robots: {:.1} vs {:.0}, ×{q:.2}", r.spec.robots, per_point(r), predicted(r.spec.robots as f64))).collect::<Vec<_>>().join("; "),
            runs.iter().map(|r| format!("{:.1}", to_router(r))).collect::<Vec<_>>().join(", ")
        ));
    }
    // Latency: the same team waits longer per round with a leader (one more hop per barrier).
    let pairs: Vec<(&Row, &Row)> = eventless(BarrierMode::Mesh)
        .into_iter()
        .filter(|r| r.spec.experiment == "idleness")
        .filter_map(|a| {
            eventless(BarrierMode::Leader).into_iter().find(|b| b.spec.experiment == a.spec.experiment && b.spec.robots == a.spec.robots).map(|b| (a, b))
        })
        .collect();
    if !pairs.is_empty() {
        let longer = pairs.iter().filter(|(a, b)| b.sync_wait_per_round_s >= a.sync_wait_per_round_s).count();
        out.push(format!(
            "Barriers (ours) — the leader's extra hop makes the team wait longer at barriers: {} in {longer} of {} team sizes (barrier wait per robot per round, mesh vs leader: {}; idleness: {}).",
            verdict(longer * 2 > pairs.len()),
            pairs.len(),
            pairs.iter().map(|(a, b)| format!("{}: {:.2} vs {:.2} s", a.spec.robots, a.sync_wait_per_round_s, b.sync_wait_per_round_s)).collect::<Vec<_>>().join(", "),
            pairs.iter().map(|(a, b)| format!("{}: {:.2} vs {:.2} s", a.spec.robots, a.avg_idleness_s, b.avg_idleness_s)).collect::<Vec<_>>().join(", ")
        ));
    }
    out
}

/// The paper's findings checked against the rows of one barrier mode.
fn paper_claims(rows: &[&Row]) -> Vec<String> {
    let mut out = Vec::new();
    let of = |e: &str, extracted: bool| -> Vec<&Row> { rows.iter().copied().filter(|r| r.spec.experiment == e && (r.spec.extract > 0) == extracted).collect() };
    fig4_claims(&of("messages", false), &of("messages", true), &mut out);
    let idle = of("idleness", false);
    fig5_claims(&idle, &mut out);
    fig6_claims(&of("environment", false), &mut out);
    for c in of("comm-loss", false) {
        out.push(format!(
            "Communication loss (the paper's section 4.3) — the patrol goes on through central's loss, a robot's loss and return, and central's return: {} ({} barriers passed across the four events, a round between each; {} of {} robots in the team at the end; worst idleness at any moment {:.1} s against {:.1} s for the whole team; timeline in comm-loss.png and comm-loss-timeline.csv).",
            verdict(c.sync_points > 0 && c.robots_after == c.spec.robots),
            c.sync_points,
            c.robots_after,
            c.spec.robots,
            c.worst_idleness_s,
            c.bound_s
        ));
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
    out
}

/// Fig. 4: messages grow faster than the team; an extraction costs fewer than the smaller team.
fn fig4_claims(eventless: &[&Row], extracted: &[&Row], out: &mut Vec<String>) {
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
    for x in extracted {
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
}

/// Fig. 5: idleness falls as robots are added, then reaches a plateau.
fn fig5_claims(idle: &[&Row], out: &mut Vec<String>) {
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
}

/// Fig. 6: in a larger environment synchronisation matters less and the plateau moves.
fn fig6_claims(env: &[&Row], out: &mut Vec<String>) {
    let (sizes, scales) = sizes_and_scales(env);
    if let ([first, .., last], [small, .., big]) = (scales.as_slice(), sizes.as_slice()) {
        let at = |n: usize, s: f64| env.iter().find(|r| r.spec.robots == n && r.spec.env_scale == s);
        let share = |r: &Row| r.sync_wait_per_round_s / (r.tour_m / crate::fleet::SPEED);
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
}
