//! The energy forecast: will a mission fall short of robots within the next minutes for want of
//! charged spares? Each robot's drain (and charge) rate is measured from its reported charge over
//! time; a mission's members that will fall below `battery_low` within `forecast_s` must leave it,
//! and each needs a spare that fits — idle robots charged enough now, and robots charging that
//! will be done by then, each usable once, in time order. The first moment the needs outrun the
//! spares is raised (`forecast/<mission>`, a warning) with who needs what when.

use std::collections::BTreeMap;

use mrmm_proto::{MissionStatus, MissionView, Priority, RobotId, RobotStatus, RobotView, Time};
use serde_json::json;

use super::rules::{candidate, fits};
use super::{AgentConfig, Candidate};
use crate::central::charging::SPARE_ABOVE;

/// A rate is measured over at least this long, seconds, and its window restarts after
/// [`WINDOW_S`] (the rate follows a robot's work as it changes).
const MEASURE_S: f64 = 30.0;
const WINDOW_S: f64 = 300.0;

/// How a robot's charge moves: a window's first sample and the rate last measured (charge per
/// second; negative while it charges).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Drain {
    t0: Time,
    c0: f64,
    charging: bool,
    rate: Option<f64>,
}

/// Follows every robot's charge: a new window when it starts or stops charging.
pub(crate) fn measure(rates: &mut BTreeMap<RobotId, Drain>, robots: &[RobotView], now: Time) {
    rates.retain(|id, _| robots.iter().any(|r| &r.id == id && r.battery.is_some()));
    for r in robots {
        let Some(b) = r.battery else { continue };
        let d = rates.entry(r.id.clone()).or_insert(Drain { t0: now, c0: b.charge, charging: b.charging, rate: None });
        if d.charging != b.charging {
            *d = Drain { t0: now, c0: b.charge, charging: b.charging, rate: None };
            continue;
        }
        if now - d.t0 >= MEASURE_S {
            d.rate = Some((d.c0 - b.charge) / (now - d.t0));
        }
        if now - d.t0 >= WINDOW_S {
            d.t0 = now;
            d.c0 = b.charge;
        }
    }
}

/// When robot `r` will fall below `low`, seconds from now (0: it is below already); None if it
/// charges or is not seen to drain.
fn low_in(r: &RobotView, d: Option<&Drain>, low: f64) -> Option<f64> {
    let b = r.battery.filter(|b| !b.charging)?;
    if b.charge < low {
        return Some(0.0);
    }
    d.and_then(|d| d.rate).filter(|&k| k > 0.0).map(|k| (b.charge - low) / k)
}

/// When charging robot `r` will be done at `charged`, seconds from now.
fn done_in(r: &RobotView, d: Option<&Drain>, charged: f64) -> Option<f64> {
    let b = r.battery.filter(|b| b.charging)?;
    let k = d.and_then(|d| d.rate).filter(|&k| k < 0.0)?;
    Some(((charged - b.charge) / -k).max(0.0))
}

/// A forecast for every running mission short of spares within `forecast_s`.
pub(crate) fn forecast(
    cfg: &AgentConfig,
    rates: &BTreeMap<RobotId, Drain>,
    robots: &[RobotView],
    missions: &[MissionView],
    now: Time,
    out: &mut BTreeMap<String, Candidate>,
) {
    if cfg.forecast_s <= 0.0 {
        return;
    }
    let by_id: BTreeMap<&RobotId, &RobotView> = robots.iter().map(|r| (&r.id, r)).collect();
    for m in missions.iter().filter(|m| m.status == MissionStatus::Running) {
        let mut needs: Vec<(f64, &RobotId)> = m
            .robots
            .iter()
            .filter_map(|id| {
                let r = by_id.get(id)?;
                low_in(r, rates.get(id), cfg.battery_low).filter(|&t| t <= cfg.forecast_s).map(|t| (t, id))
            })
            .collect();
        if needs.is_empty() {
            continue;
        }
        needs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let pool = robots.iter().filter(|r| r.mission.is_none() && r.status != RobotStatus::Lost && fits(r, m));
        let mut spares: Vec<f64> = pool
            .filter_map(|r| match r.battery {
                None => Some(0.0),
                Some(b) if !b.charging => (b.charge >= SPARE_ABOVE).then_some(0.0),
                Some(_) => done_in(r, rates.get(&r.id), cfg.charged).filter(|&t| t <= cfg.forecast_s),
            })
            .collect();
        spares.sort_by(f64::total_cmp);
        // Each need takes the first spare ready by then; a team may lose down to its `min`.
        let mut unmet: Vec<(f64, &RobotId)> = Vec::new();
        let mut next = 0;
        for &(t, r) in &needs {
            if spares.get(next).is_some_and(|&s| s <= t) {
                next += 1;
            } else {
                unmet.push((t, r));
            }
        }
        let slack: usize = m.team_views.iter().map(|t| t.members.len().saturating_sub(t.min)).sum();
        let Some(&(when, who)) = unmet.get(slack) else { continue };
        let id = format!("forecast/{}", m.name);
        let reason = format!(
            "mission {} will be short of robots in about {:.0} min: {} of its robots need charging within {:.0} min ({who} first to go unreplaced) and only {} spare(s) that fit it are ready in time{}",
            m.name,
            when / 60.0,
            needs.len(),
            cfg.forecast_s / 60.0,
            next,
            if cfg.charging { "" } else { " (the charging policy is off)" }
        );
        let evidence = json!({
            "mission": m.name,
            "short_in_s": when,
            "short_by": unmet.len() - slack,
            "needs": needs.iter().map(|(t, r)| json!({"robot": r, "low_in_s": t})).collect::<Vec<_>>(),
            "spares_ready_in_s": spares,
        });
        out.insert(id.clone(), candidate(id, Priority::Warning, reason, evidence, now, None));
    }
}
