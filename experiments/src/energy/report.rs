//! The energy experiment's CSV, figure and summary, and its targets checked.

use std::path::Path;

use super::{Day, Policy, Row, Trace, DT, LOOK_S, MAP};

/// results-energy.csv, energy.png and summary-energy.md in `out`.
pub fn write(out: &Path, day: &Day, runs: &[(Row, Trace)], command: &str, elapsed: f64) -> anyhow::Result<()> {
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("results-energy.csv"), csv(runs))?;
    plot(out, runs)?;
    std::fs::write(out.join("summary-energy.md"), summary(day, runs, command, elapsed))?;
    Ok(())
}

fn csv(runs: &[(Row, Trace)]) -> String {
    let mut csv = String::from(
        "policy,robots,avg_idleness_s,worst_idleness_s,short_of_team_s,lowest_charge,robots_under_5pct,robots_dry,errands,replans,handovers,charging_s\n",
    );
    for (r, _) in runs {
        csv.push_str(&format!(
            "{},{},{:.2},{:.2},{:.1},{:.4},{},{},{},{},{},{:.0}\n",
            r.policy.name(),
            r.robots,
            r.avg_s,
            r.worst_s,
            r.short_s,
            r.lowest,
            r.under_5,
            r.died,
            r.errands,
            r.replans,
            r.handovers,
            r.charging_s
        ));
    }
    csv
}

fn plot(out: &Path, runs: &[(Row, Trace)]) -> anyhow::Result<()> {
    let team = runs.iter().map(|(_, t)| (t.policy.name(), t.team.clone())).collect();
    // Every policy in both panels, so that each keeps its colour (no batteries: always full).
    let lowest = runs.iter().map(|(_, t)| (t.policy.name(), t.lowest.clone())).collect();
    crate::plot::timeline(
        &out.join("energy.png"),
        &crate::plot::Timeline {
            title: "A patrol's day on batteries (Open-RMF office, 6 robots)",
            x_label: "hours",
            panels: vec![("robots patrolling", team), ("lowest charge", lowest)],
            events: &[],
        },
    )
}

/// The targets of issue 53 for mrmm's policy: whether each is met, in words.
pub fn targets(day: &Day, runs: &[(Row, Trace)]) -> Vec<(String, bool)> {
    let find = |p: Policy| runs.iter().map(|(r, _)| r).find(|r| r.policy == p);
    let (Some(reference), Some(mrmm)) = (find(Policy::Unlimited), find(Policy::Mrmm)) else { return vec![] };
    let ratio = mrmm.worst_s / reference.worst_s;
    vec![
        (format!("no robot ever below 5 % (lowest charge {:.1} %)", 100.0 * mrmm.lowest), mrmm.under_5 == 0),
        (format!("the patrol never below its min of {} robots (short {:.0} s of the day)", day.team, mrmm.short_s), mrmm.short_s == 0.0),
        (format!("worst idleness within 1.3 × its value without batteries ({:.0} s ÷ {:.0} s = {ratio:.2})", mrmm.worst_s, reference.worst_s), ratio <= 1.3),
    ]
}

fn summary(day: &Day, runs: &[(Row, Trace)], command: &str, elapsed: f64) -> String {
    let mut md = format!(
        "# A patrol's day on batteries\n\n`{command}` — {elapsed:.0} s on this machine.\n\n\
         {team} robots patrol every vertex of Open-RMF's {MAP} graph (two chargers) for {hours:.0} simulated hours \
         with mrmm's patrol planner, driven by the robots' own executors and bodies (step {DT} s). A full charge \
         drives {life:.1} h at top speed (1 m/s; standing draws a fifth of that power), a charger fills an \
         empty battery in {charge:.1} h; the patrol's robots start with charges spread from 100 to {low:.0} %, \
         spares full. Central's charging policy (`mrmm_core::central::charging`, thresholds {go:.0} → {done:.0} %) \
         looks every {LOOK_S} s; a spare, sent to wait where the low robot's leg ends, takes its plan from where it is and the others go \
         on (a hand-over, as the mission's manager does it); other moves replan the patrol from where the robots \
         stand. A robot that runs dry stops, and the patrol is replanned without it. Idleness as \
         patrolling_sim measures it, from the first start barrier, visits by the patrol's robots only, the \
         time since a vertex's last visit at the day's end counted. Robots drive through each other here \
         (no traffic).\n\n![energy](energy.png)\n\n\
         | policy | robots | avg idleness s | worst idleness s | short of the team s | lowest charge | under 5 % | ran dry | errands | replans | hand-overs |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
        team = day.team,
        hours = day.length_s / 3600.0,
        life = day.life_s / 3600.0,
        charge = day.charge_s / 3600.0,
        low = 100.0 * day.lowest_start,
        go = 100.0 * day.charging.go_below,
        done = 100.0 * day.charging.done_above,
    );
    for (r, _) in runs {
        md.push_str(&format!(
            "| {} | {} | {:.1} | {:.1} | {:.0} | {:.1} % | {} | {} | {} | {} | {} |\n",
            r.policy.name(),
            r.robots,
            r.avg_s,
            r.worst_s,
            r.short_s,
            100.0 * r.lowest,
            r.under_5,
            r.died,
            r.errands,
            r.replans,
            r.handovers
        ));
    }
    md.push_str("\nTargets (issue 53), mrmm's policy:\n\n");
    for (what, met) in targets(day, runs) {
        md.push_str(&format!("- {what}: {}\n", if met { "met" } else { "**not met**" }));
    }
    md
}
