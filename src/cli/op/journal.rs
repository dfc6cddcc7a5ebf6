//! `mrmm op journal`: central's journal (`mrmm/system/journal?since=SEQ`), page after page, as
//! lines — or the raw entries with `--json`.

use mrmm_net::client::Client;
use mrmm_proto::{JournalEntry, JournalEvent, JournalPage, Key};

/// Prints every entry after `since` (all pages).
pub async fn exec(client: &Client, since: u64, json: bool) -> anyhow::Result<()> {
    let none = None::<&()>;
    let mut since = since;
    let mut all = Vec::new();
    loop {
        let page: JournalPage = client.query(format!("{}?since={since}", Key::SystemJournal), none).await?;
        let more = page.more && page.next > since;
        since = page.next;
        all.extend(page.entries);
        if !more {
            break;
        }
    }
    if json {
        return super::print_json(&serde_json::to_value(&all)?);
    }
    if all.is_empty() {
        println!("no entries");
    }
    for e in &all {
        println!("{}", line(e));
    }
    Ok(())
}

/// One entry as a line: sequence, UTC time, what happened.
pub fn line(e: &JournalEntry) -> String {
    let what = match &e.event {
        JournalEvent::MissionDefined { mission, host, recipe, spec, .. } => {
            let params = spec.as_ref().map(|s| s.params.keys().cloned().collect::<Vec<_>>().join(",")).unwrap_or_default();
            format!("mission {mission} defined ({recipe} on {host}{})", if params.is_empty() { String::new() } else { format!("; params {params}") })
        }
        JournalEvent::MissionRemoved { mission, terminated: true } => format!("mission {mission} terminated"),
        JournalEvent::MissionRemoved { mission, terminated: false } => format!("mission {mission} removed (it never ran)"),
        JournalEvent::RobotAssigned { robot, mission: Some(m) } => format!("robot {robot} in mission {m}"),
        JournalEvent::RobotAssigned { robot, mission: None } => format!("robot {robot} in no mission"),
        JournalEvent::RobotReleasing { robot, mission: Some(m) } => format!("robot {robot} being let go by {m}"),
        JournalEvent::RobotReleasing { robot, mission: None } => format!("robot {robot} let go"),
        JournalEvent::RobotLetGo { robot, mission } => format!("robot {robot} let go by {mission}"),
        JournalEvent::RobotErrand { robot, errand: Some(e) } => {
            let left = e.left.as_ref().map(|(m, _)| format!(", left mission {m}")).unwrap_or_default();
            let spare = e.spare.as_ref().map(|s| format!(", {s} in its place")).unwrap_or_default();
            format!("robot {robot} to charge at {} of map {}{left}{spare}", e.charger.name, e.map)
        }
        JournalEvent::RobotErrand { robot, errand: None } => format!("robot {robot}: charging errand over"),
        JournalEvent::Command { by, command, request } => format!("{by}: {command} {request}"),
        JournalEvent::RobotLost { robot } => format!("robot {robot} lost"),
        JournalEvent::RobotBack { robot } => format!("robot {robot} back"),
        JournalEvent::RobotFlapping { robot, losses, alive } => {
            format!("robot {robot} lost {losses} more times, then quiet ({})", if *alive { "alive" } else { "lost" })
        }
        JournalEvent::ManagerChanged { mission, manager, chain_epoch } => format!("mission {mission} managed by {manager} (chain epoch {chain_epoch})"),
        JournalEvent::Replanned { mission, plan_epoch, robots } => format!("mission {mission} replanned (epoch {plan_epoch}) for {}", robots.join(", ")),
        JournalEvent::MissionRestarted { mission, robots } => format!("mission {mission} started again with {}", robots.join(", ")),
        JournalEvent::CentralStarted { missions, robots, terminated } => {
            format!("central started: {missions} missions, {robots} robots placed, {terminated} missions terminated, from the journal")
        }
    };
    format!("{:>6}  {}  {what}", e.seq, utc(e.at_ms))
}

/// `YYYY-MM-DD HH:MM:SS.mmm` (UTC) of milliseconds since the Unix epoch.
fn utc(ms: u64) -> String {
    let (secs, milli) = (ms / 1000, ms % 1000);
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02}.{milli:03}", rem / 3600, rem % 3600 / 60, rem % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_utc_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00:00.000");
        assert_eq!(utc(1_795_521_663_120), "2026-11-24 12:01:03.120");
        assert_eq!(utc(951_782_400_000), "2000-02-29 00:00:00.000");
    }
}
