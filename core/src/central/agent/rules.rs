//! The agent's rules: from a snapshot (and a little memory) to candidate advice, keyed by a stable
//! id per situation.

use std::collections::BTreeMap;

use mrmm_proto::traffic::TrafficView;
use mrmm_proto::{Advice, MissionName, MissionStatus, MissionView, PlanSummary, Priority, RobotId, RobotMove, RobotStatus, RobotView, Time};
use serde_json::json;

use super::{AgentConfig, Candidate, Memory};
use crate::central::charging::{mission_of, Mode};

pub(super) fn candidate(id: String, priority: Priority, reason: String, evidence: serde_json::Value, now: Time, action: Option<RobotMove>) -> Candidate {
    let suggestion = action.as_ref().map(|m| format!("mrmm op move {} {}", m.robot, m.to.as_ref().map(|x| x.as_str()).unwrap_or("none")));
    Candidate { advice: Advice { id, priority, reason, evidence, suggestion, action: action.clone(), since: now, acted: false, outcome: None }, action }
}

/// Patrol worst idleness predicted with `n` robots: `L / (n · v)` from the mission's plan.
fn patrol_prediction(m: &MissionView, n: usize) -> Option<f64> {
    match &m.summary {
        Some(PlanSummary::Patrol(p)) if n > 0 && p.team_speed > 0.0 => Some(p.length / (n as f64 * p.team_speed)),
        _ => None,
    }
}

/// Whether robot `r` has every capability mission `m` requires.
pub(super) fn fits(r: &RobotView, m: &MissionView) -> bool {
    mrmm_proto::lacking(&r.capabilities, &m.requires).is_empty()
}

/// A robot that can be spared for `target` (one with what it requires): an idle one first, else
/// one from the largest other mission that keeps at least one robot (coverage missions before
/// patrols).
fn donor(robots: &[RobotView], missions: &[MissionView], target: &str) -> Option<(RobotId, Option<MissionName>)> {
    let fit = |r: &RobotView| missions.iter().find(|m| m.name == target).is_none_or(|m| fits(r, m));
    if let Some(r) = robots.iter().find(|r| r.status == RobotStatus::Idle && fit(r)) {
        return Some((r.id.clone(), None));
    }
    let by_id: BTreeMap<&str, &RobotView> = robots.iter().map(|r| (r.id.as_str(), r)).collect();
    let spare = |m: &MissionView| m.robots.iter().rev().find(|id| by_id.get(id.as_str()).is_some_and(|r| fit(r))).cloned();
    missions
        .iter()
        .filter(|m| m.name != target && m.robots.len() >= 2 && m.status == MissionStatus::Running && spare(m).is_some())
        .max_by_key(|m| (m.planner == "coverage", m.robots.len()))
        .and_then(|m| spare(m).map(|r| (r, Some(m.name.clone()))))
}

/// Advice when robot `r`, out of mission `m` now, lacks what `m` requires: it was taken out for
/// that; a robot that has it is suggested.
fn unfit(robots: &[RobotView], missions: &[MissionView], r: &RobotView, m: &MissionView, now: Time) -> Option<Candidate> {
    let lacks = mrmm_proto::lacking(&r.capabilities, &m.requires);
    if lacks.is_empty() {
        return None;
    }
    let give = donor(robots, missions, m.name.as_str());
    let then = match &give {
        Some((id, from)) => format!(": add {id}{}, which has {}", from.as_ref().map(|f| format!(" from {f}")).unwrap_or_default(), lacks.join(", ")),
        None => format!(", and no robot with {} can be spared", lacks.join(", ")),
    };
    let reason = format!("robot {} no longer has {}, which mission {} requires: it left the mission{then}", r.id, lacks.join(", "), m.name);
    let action = give.as_ref().map(|(id, _)| RobotMove { robot: id.clone(), to: Some(m.name.clone()), replaces: None });
    let evidence = json!({"robot": r.id, "mission": m.name, "lacks": lacks, "robots": m.robots.len(), "donor": give.as_ref().map(|g| &g.0)});
    Some(candidate(format!("capability/{}", r.id), Priority::Warning, reason, evidence, now, action))
}

/// Advice for each leaf team of mission `m` below its `min` (after a loss: the mission goes on
/// with the members it has): critical, with a robot that fits the team — an idle one, else one
/// from the largest other running mission that keeps at least one.
fn short_teams(robots: &[RobotView], missions: &[MissionView], m: &MissionView, now: Time) -> Vec<Candidate> {
    let mut out = Vec::new();
    for t in m.team_views.iter().filter(|t| t.members.len() < t.min) {
        let fit = |r: &RobotView| t.robot_type.as_ref().is_none_or(|ty| *ty == r.robot_type) && mrmm_proto::lacking(&r.capabilities, &t.requires).is_empty();
        let idle = robots.iter().find(|r| r.status == RobotStatus::Idle && fit(r)).map(|r| (r.id.clone(), None));
        let by_id: BTreeMap<&str, &RobotView> = robots.iter().map(|r| (r.id.as_str(), r)).collect();
        let spare = |o: &MissionView| o.robots.iter().rev().find(|id| by_id.get(id.as_str()).is_some_and(|r| fit(r))).cloned();
        let give = idle.or_else(|| {
            missions
                .iter()
                .filter(|o| o.name != m.name && o.robots.len() >= 2 && o.status == MissionStatus::Running)
                .filter_map(|o| Some((o.robots.len(), spare(o)?, o.name.clone())))
                .max_by_key(|(n, _, _)| *n)
                .map(|(_, id, from)| (id, Some(from)))
        });
        let then = match &give {
            Some((id, from)) => format!(": add {id}{} ({})", from.as_ref().map(|f| format!(" from {f}")).unwrap_or_default(), t.wants),
            None => format!(", and no robot that fits it ({}) can be spared", t.wants),
        };
        let reason = format!("team {} of mission {} has {} of the {} members it needs{then}", t.team, m.name, t.members.len(), t.min);
        let action = give.as_ref().map(|(id, _)| RobotMove { robot: id.clone(), to: Some(m.name.clone()), replaces: None });
        let evidence = json!({"mission": m.name, "team": t.team, "members": t.members, "min": t.min, "donor": give.as_ref().map(|g| &g.0)});
        out.push(candidate(format!("team/{}", t.team), Priority::Critical, reason, evidence, now, action));
    }
    out
}

/// All candidate advice for this snapshot.
pub(crate) fn evaluate(
    cfg: &AgentConfig,
    mem: &mut Memory,
    now: Time,
    robots: &[RobotView],
    missions: &[MissionView],
    traffic: &[TrafficView],
) -> BTreeMap<String, Candidate> {
    let mut out = BTreeMap::new();
    lost_robots(cfg, mem, robots, missions, now, &mut out);
    below_standard(robots, missions, now, &mut out);
    // Leaf teams short of members.
    for m in missions.iter().filter(|m| matches!(m.status, MissionStatus::Running | MissionStatus::Stalled)) {
        for c in short_teams(robots, missions, m, now) {
            out.insert(c.advice.id.clone(), c);
        }
    }
    idle_robots(robots, missions, now, &mut out);
    managers(cfg, mem, missions, now, &mut out);
    // A robot waiting in traffic is not stuck: it is told why it waits instead.
    let waiting: std::collections::BTreeSet<&RobotId> = traffic.iter().flat_map(|m| &m.robots).filter(|t| t.waiting_s.is_some()).map(|t| &t.robot).collect();
    stuck_robots(cfg, mem, robots, &waiting, now, &mut out);
    blocked_in_traffic(cfg, robots, traffic, now, &mut out);
    batteries(cfg, robots, missions, now, &mut out);
    short_of_reach(robots, missions, now, &mut out);
    super::forecast::measure(&mut mem.drains, robots, now);
    super::forecast::forecast(cfg, &mem.drains, robots, missions, now, &mut out);
    out
}

/// A charge below this counts as empty (the robot cannot drive).
const EMPTY: f64 = 0.005;

/// Robots whose battery is empty (critical: it stands where it died) or low, not charging. A low
/// robot of a mission that charges on the operator's word (`charging=ask`) comes with the order
/// that sends it; one of a mission that never charges (`off`) says so.
fn batteries(cfg: &AgentConfig, robots: &[RobotView], missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    for r in robots.iter().filter(|r| r.status != RobotStatus::Lost) {
        let Some(b) = r.battery.filter(|b| !b.charging && b.charge < cfg.battery_low.max(EMPTY)) else { continue };
        // Two ids: an advice keeps its priority, and empty is news after low.
        let at = r.pose.map(|p| format!(" at ({:.1}, {:.1})", p.x, p.y)).unwrap_or_default();
        let mode = mission_of(r, missions).map(|m| (m.name.clone(), Mode::of(m)));
        let (id, priority, reason) = if b.charge < EMPTY {
            (format!("battery/{}/empty", r.id), Priority::Critical, format!("robot {}'s battery is empty: it stands{at}", r.id))
        } else {
            let reach = b.reach_m.map(|m| format!(", {m:.0} m left")).unwrap_or_default();
            let why = match &mode {
                Some((m, Mode::Ask)) => format!(": mission {m} charges its robots on the operator's word"),
                Some((m, Mode::Off)) => format!(": mission {m} does not charge its robots (charging=off)"),
                _ => String::new(),
            };
            (
                format!("battery/{}/low", r.id),
                Priority::Warning,
                format!("robot {}'s battery is at {:.0} %{reach}, and it is not charging{why}", r.id, b.charge * 100.0),
            )
        };
        let mut c = candidate(id.clone(), priority, reason, json!({"robot": r.id, "charge": b.charge, "reach_m": b.reach_m}), now, None);
        if matches!(mode, Some((_, Mode::Ask))) && b.charge >= EMPTY {
            c.advice.suggestion = Some(format!("mrmm op charge {}", r.id));
        }
        out.insert(id, c);
    }
}

/// Members a mission's plan holds for want of reach (`MissionView::held`), where the mission
/// does not send its robots to charge by itself (`charging=ask`, with the order that sends it;
/// `off`): they stand idle in the mission until the operator acts. With `auto` central sends
/// them at its next look, and nothing is raised.
fn short_of_reach(robots: &[RobotView], missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    for m in missions {
        let mode = Mode::of(m);
        if mode == Mode::Auto {
            continue;
        }
        for r in robots.iter().filter(|r| m.held.contains(&r.id) && r.status != RobotStatus::Lost) {
            let reach = r.battery.and_then(|b| b.reach_m);
            let left = reach.map(|v| format!(" (its battery takes it {v:.0} m)")).unwrap_or_default();
            let why = match mode {
                Mode::Ask => "it charges on the operator's word",
                _ => "it does not charge its robots (charging=off)",
            };
            let id = format!("reach/{}", r.id);
            let reason = format!("robot {} stands idle in mission {}: its reach is short of every leg of the plan{left}, and {why}", r.id, m.name);
            let mut c = candidate(id.clone(), Priority::Warning, reason, json!({"robot": r.id, "mission": m.name, "reach_m": reach}), now, None);
            if mode == Mode::Ask {
                c.advice.suggestion = Some(format!("mrmm op charge {}", r.id));
            }
            out.insert(id, c);
        }
    }
}

/// A robot blocked in traffic (no way around the robots in its way), or waiting for the same
/// robots longer than `traffic_wait_s`: who is in the way, and the move that would clear it —
/// a lost robot taken off the lanes, an idle one driven away, a mission's robot stepping back
/// (its mission paused, or the robot taken out of it).
fn blocked_in_traffic(cfg: &AgentConfig, robots: &[RobotView], traffic: &[TrafficView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    let by_id: BTreeMap<&str, &RobotView> = robots.iter().map(|r| (r.id.as_str(), r)).collect();
    for map in traffic {
        for t in &map.robots {
            let long = t.waiting_s.is_some_and(|w| w >= cfg.traffic_wait_s);
            let by = if t.blocked.is_empty() { &t.waits_for } else { &t.blocked };
            if by.is_empty() || (t.blocked.is_empty() && !long) {
                continue;
            }
            let first = &by[0];
            let blocker = by_id.get(first.as_str());
            let suggestion = match blocker {
                Some(b) if b.status == RobotStatus::Lost => {
                    format!("robot {first} is lost where it stands: restart it there, or take it away and free its lanes: mrmm op traffic --clear {first}")
                }
                Some(b) if b.mission.is_none() => format!("drive {first} out of the way: mrmm op goto {first} X Y"),
                Some(b) => {
                    format!("mrmm op move {first} none (out of mission {}), or pause the mission", b.mission.as_ref().map(|x| x.as_str()).unwrap_or("?"))
                }
                None => format!("mrmm op traffic {}", &map.map[..8.min(map.map.len())]),
            };
            let how =
                if t.blocked.is_empty() { format!("has waited {:.0} s in traffic", t.waiting_s.unwrap_or(0.0)) } else { "is blocked in traffic".to_string() };
            let names: Vec<&str> = by.iter().map(RobotId::as_str).collect();
            let reason = format!("robot {} {how} for {}", t.robot, names.join(", "));
            let evidence = json!({"robot": t.robot, "map": map.map, "waits_for": by, "waiting_s": t.waiting_s, "blocked": !t.blocked.is_empty(),
                                  "route": t.route, "reached": t.reached, "granted": t.granted});
            let id = format!("traffic/{}", t.robot);
            let advice = Advice {
                id: id.clone(),
                priority: Priority::Warning,
                reason,
                evidence,
                suggestion: Some(suggestion),
                action: None,
                since: now,
                acted: false,
                outcome: None,
            };
            out.insert(id, Candidate { advice, action: None });
        }
    }
}

/// A robot lost, and what was done about it; a robot taken out of its mission because it no longer
/// has what the mission requires (an event).
fn lost_robots(cfg: &AgentConfig, mem: &mut Memory, robots: &[RobotView], missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    let by_name: BTreeMap<&str, &MissionView> = missions.iter().map(|m| (m.name.as_str(), m)).collect();
    // Robot lost, and what was done about it; a robot taken out of its mission because it no
    // longer has what the mission requires (an event).
    for r in robots {
        if r.status != RobotStatus::Lost {
            match &r.mission {
                Some(m) => {
                    mem.last_mission.insert(r.id.clone(), m.clone());
                }
                None => {
                    if let Some(c) = mem.last_mission.remove(&r.id).and_then(|m| unfit(robots, missions, r, by_name.get(m.as_str())?, now)) {
                        mem.events.insert(c.advice.id.clone(), (c, now + cfg.event_advice_s));
                    }
                }
            }
            continue;
        }
        let was_in = r.last_mission.clone().or_else(|| mem.last_mission.get(&r.id).cloned());
        let (reason, evidence, action) = match was_in.as_ref().map(|x| x.as_str()).and_then(|m| by_name.get(m).map(|v| (m, v))) {
            Some((m, v)) => {
                let action =
                    donor(robots, missions, m).filter(|(_, from)| from.is_none()).map(|(id, _)| RobotMove { robot: id, to: Some(m.into()), replaces: None });
                (
                    format!("robot {} lost; mission {m} replanned for its {} remaining robots", r.id, v.robots.len()),
                    json!({"robot": r.id, "mission": m, "remaining": v.robots.len(), "epoch": v.manager.epoch}),
                    action,
                )
            }
            None => (format!("robot {} lost", r.id), json!({"robot": r.id}), None),
        };
        out.insert(format!("lost/{}", r.id), candidate(format!("lost/{}", r.id), Priority::Critical, reason, evidence, now, action));
    }
}

/// A mission below its standard, with the predicted benefit of one more robot.
fn below_standard(robots: &[RobotView], missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    for m in missions {
        let (Some(limit), Some(worst)) = (m.params.get("max_worst_idleness").and_then(|v| v.parse::<f64>().ok()), m.metrics.worst_idleness) else {
            continue;
        };
        if worst <= limit {
            continue;
        }
        let n = m.robots.len();
        let predicted = patrol_prediction(m, n + 1);
        let predicted_now = patrol_prediction(m, n);
        let give = donor(robots, missions, m.name.as_str());
        let reason = match (&give, predicted_now, predicted) {
            (Some((id, from)), Some(now_p), Some(p)) => format!(
                "{} below standard (worst idleness {worst:.0} s > {limit:.0} s): move {id}{} to {}: predicted worst idleness {now_p:.0} s → {p:.0} s",
                m.name,
                from.as_ref().map(|f| format!(" from {f}")).unwrap_or_default(),
                m.name
            ),
            _ => format!("{} below standard (worst idleness {worst:.0} s > {limit:.0} s) and no robot to spare", m.name),
        };
        let action = give.as_ref().map(|(id, _)| RobotMove { robot: id.clone(), to: Some(m.name.clone()), replaces: None });
        let evidence = json!({"mission": m.name, "worst_idleness": worst, "standard": limit, "robots": n,
                              "predicted": predicted_now, "predicted_with_one_more": predicted, "donor": give.as_ref().map(|g| &g.0), "donor_mission": give.and_then(|g| g.1)});
        let id = format!("standard/{}", m.name);
        out.insert(id.clone(), candidate(id, Priority::Warning, reason, evidence, now, action));
    }
}

/// Idle robots while missions run: where one would help most.
fn idle_robots(robots: &[RobotView], missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    let idle: Vec<&RobotView> = robots.iter().filter(|r| r.status == RobotStatus::Idle).collect();
    let running: Vec<&MissionView> = missions.iter().filter(|m| m.status == MissionStatus::Running).collect();
    if !idle.is_empty() && !running.is_empty() {
        let best = running
            .iter()
            .filter_map(|m| Some((m, idle.iter().find(|r| fits(r, m))?, patrol_prediction(m, m.robots.len())? - patrol_prediction(m, m.robots.len() + 1)?)))
            .max_by(|a, b| a.2.total_cmp(&b.2));
        let ids: Vec<&str> = idle.iter().map(|r| r.id.as_str()).collect();
        let (reason, action, gain) = match best {
            Some((m, r, gain)) => (
                format!("{} idle robot(s) ({}): adding {} to {} cuts its predicted worst idleness by {gain:.0} s", ids.len(), ids.join(", "), r.id, m.name),
                Some(RobotMove { robot: r.id.clone(), to: Some(m.name.clone()), replaces: None }),
                Some(gain),
            ),
            None => (format!("{} idle robot(s) available ({})", ids.len(), ids.join(", ")), None, None),
        };
        out.insert("idle".into(), candidate("idle".into(), Priority::Info, reason, json!({"idle": ids, "gain_s": gain}), now, action));
    }
}

/// Mission managers: host lost (stands while stalled), or moved to another node (an event).
fn managers(cfg: &AgentConfig, mem: &mut Memory, missions: &[MissionView], now: Time, out: &mut BTreeMap<String, Candidate>) {
    for m in missions {
        if m.status == MissionStatus::Stalled {
            if let Some(e) = &m.error {
                let id = format!("manager/{}", m.name);
                out.insert(
                    id.clone(),
                    candidate(id, Priority::Critical, format!("mission {}: {e}", m.name), json!({"mission": m.name, "node": m.manager.node}), now, None),
                );
            }
        }
        let prev = mem.managers.insert(m.name.clone(), m.manager.node.clone());
        if let Some(prev) = prev.filter(|p| *p != m.manager.node) {
            let id = format!("failover/{}", m.name);
            let c = candidate(
                id.clone(),
                Priority::Warning,
                format!("mission {}: manager moved from {prev} to {} (epoch {})", m.name, m.manager.node, m.manager.epoch),
                json!({"mission": m.name, "from": prev, "to": m.manager.node, "epoch": m.manager.epoch}),
                now,
                None,
            );
            mem.events.insert(id, (c, now + cfg.event_advice_s));
        }
    }
    mem.events.retain(|_, (_, until)| *until > now);
    for (id, (c, _)) in &mem.events {
        out.insert(id.clone(), c.clone());
    }
}

/// Robots driving somewhere without getting anywhere.
fn stuck_robots(
    cfg: &AgentConfig,
    mem: &mut Memory,
    robots: &[RobotView],
    in_traffic: &std::collections::BTreeSet<&RobotId>,
    now: Time,
    out: &mut BTreeMap<String, Candidate>,
) {
    for r in robots {
        if r.battery.is_some_and(|b| b.charge < EMPTY) {
            // Its battery is empty: the battery rule says so.
            continue;
        }
        if let Some(why) = &r.stuck {
            // The robot says so itself (its navigator refused or aborted the goal).
            let id = format!("stuck/{}", r.id);
            let reason = format!("robot {} cannot get to its goal: {why}", r.id);
            out.insert(id.clone(), candidate(id, Priority::Warning, reason, json!({"robot": r.id, "why": why}), now, None));
            continue;
        }
        let Some(pose) = r.pose else { continue };
        let driving = r.status == RobotStatus::Busy && r.behaviour.as_deref().is_some_and(|b| b.contains("goto"));
        let entry = mem.last_moved.entry(r.id.clone()).or_insert((pose, now));
        let moved = (pose.x - entry.0.x).hypot(pose.y - entry.0.y) > cfg.stuck_distance;
        if moved || !driving || in_traffic.contains(&r.id) {
            *entry = (pose, now);
            continue;
        }
        let still = now - entry.1;
        if still >= cfg.stuck_after_s {
            let id = format!("stuck/{}", r.id);
            let reason = format!("robot {} has not moved for {still:.0} s while {}", r.id, r.behaviour.as_deref().unwrap_or("driving"));
            out.insert(id.clone(), candidate(id, Priority::Warning, reason, json!({"robot": r.id, "still_s": still, "x": pose.x, "y": pose.y}), now, None));
        }
    }
}
