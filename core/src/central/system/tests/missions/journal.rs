//! The journal: every change goes out first, replays to exactly what the manager holds, and a
//! manager restored from it restarts missions no one runs, keeps terminated ones ended, and holds
//! membership to it.

use super::*;
use crate::at;
use mrmm_proto::{JournalEvent, Time};

/// Drives like the driver: journal entries are committed to `disk` and must come first.
fn drive_journaled(sm: &mut SystemManager, disk: &mut Durable, now: Time, ev: Event) -> Vec<Command> {
    let cmds = sm.handle(now, ev);
    let mut out = Vec::new();
    for (i, c) in cmds.into_iter().enumerate() {
        match c {
            Command::Journal(entries) => {
                assert_eq!(i, 0, "the journal comes before anything else");
                for e in &entries {
                    disk.apply(e);
                }
            }
            Command::DryRun(d) => {
                let result = d.run();
                out.extend(drive_journaled(sm, disk, now, Event::DryRunDone { id: d.id, result }));
            }
            other => out.push(other),
        }
    }
    assert_eq!(*disk, sm.durable(), "what the journal replays to is what the manager holds");
    out
}

fn started_view(name: &str, host: &str, robots: &[String]) -> Box<MissionView> {
    Box::new(MissionView {
        name: name.into(),
        recipe: "patrol".into(),
        planner: "patrol".into(),
        status: MissionStatus::Running,
        robots: robots.iter().map(Into::into).collect(),
        lost: vec![],
        stuck: Default::default(),
        held: vec![],
        teams: Default::default(),
        team_views: vec![],
        manager: ManagerView { node: host.into(), epoch: 1, chain_epoch: 1, chain: vec![], uncommitted_s: None },
        metrics: MissionMetrics::default(),
        summary: None,
        summary_unchanged: false,
        params: Default::default(),
        error: None,
        plans: None,
        map: None,
        requires: vec![],
    })
}

/// A fleet of `ids` with mission `p1` (r1, r2) running and mission `gone` terminated; its disk.
fn with_journal(ids: &[&str]) -> (SystemManager, Durable) {
    let mut sm = with_host(ids);
    let mut disk = Durable::default();
    for (name, robots, req) in [("p1", r#"["r1", "r2"]"#, 1), ("gone", r#"["r3"]"#, 2)] {
        let body = format!(r#"{{"name": "{name}", "recipe": "patrol", "robots": {robots}, {WAYPOINTS}}}"#);
        let cmds = drive_journaled(&mut sm, &mut disk, at(1.0), Event::Operator { req: Req::Query(req), request: Request::Create(decode(&body)) });
        let start = cmds.iter().find_map(|c| match c {
            Command::StartMission { host, start } => Some((host.to_string(), start.members.iter().map(|m| m.spec.id.to_string()).collect::<Vec<_>>())),
            _ => None,
        });
        let (host, robots) = start.expect("a start");
        let cmds = drive_journaled(&mut sm, &mut disk, at(1.5), Event::MissionStarted { mission: name.into(), result: Ok(started_view(name, &host, &robots)) });
        assert!(cmds.iter().any(|c| matches!(c, Command::Reply { result: Ok(_), .. })), "{cmds:?}");
    }
    drive_journaled(&mut sm, &mut disk, at(2.0), Event::Operator { req: Req::Query(3), request: Request::Terminate(decode(r#"{"name": "gone"}"#)) });
    (sm, disk)
}

#[test]
fn every_change_is_on_disk_before_it_is_said_and_replays_exactly() {
    let (mut sm, mut disk) = with_journal(&["r1", "r2", "r3", "r4"]);
    assert_eq!(disk.assignment.get("r1").map(|m| m.as_str()), Some("p1"));
    assert!(disk.terminated.contains("gone") && !disk.missions.contains_key("gone"));
    let spec = disk.missions.get("p1").and_then(|d| d.spec.clone()).expect("the whole spec");
    assert!(spec.recipe_xml.contains("<recipe") && spec.params.contains_key("waypoints"), "{spec:?}");
    // A move: the entry comes in the same batch as the reply, before it.
    let cmds = sm.handle(at(3.0), Event::Operator { req: Req::Query(4), request: Request::Move(decode(r#"{"robot": "r4", "to": "p1"}"#)) });
    let Some(Command::Journal(entries)) = cmds.first() else { panic!("journal first: {cmds:?}") };
    assert!(entries.contains(&JournalEvent::RobotAssigned { robot: "r4".into(), mission: Some("p1".into()) }), "{entries:?}");
    assert!(entries.iter().any(|e| matches!(e, JournalEvent::Command { command, .. } if command == "robot move")), "{entries:?}");
    for e in entries {
        disk.apply(e);
    }
    assert_eq!(disk, sm.durable());
    // Telemetry that changes nothing durable writes nothing.
    let cmds = sm.handle(at(3.5), Event::Telemetry(Box::new(telemetry("r3", 9, Behaviour::Hold))));
    assert!(!cmds.iter().any(|c| matches!(c, Command::Journal(_))), "{cmds:?}");
    // A loss is history.
    let cmds = sm.handle(at(4.0), Event::RobotGone { id: "r2".into() });
    assert_eq!(cmds.first(), Some(&Command::Journal(vec![JournalEvent::RobotLost { robot: "r2".into() }])));
}

/// A manager started from `disk` with `alive` robots back (running nothing) and central's host up.
fn restored(disk: &Durable, alive: &[&str]) -> SystemManager {
    let mut sm = SystemManager::restore("node".into(), at(0.0), disk.clone());
    sm.handle(at(0.0), Event::HostAlive { node: "central".into() });
    for id in alive {
        sm.handle(at(0.0), Event::RobotAlive { id: (*id).into() });
        sm.handle(at(0.0), Event::RobotRegistered(info(id)));
        sm.handle(at(0.0), Event::Telemetry(Box::new(telemetry(id, 1, Behaviour::Hold))));
    }
    sm
}

#[test]
fn after_a_power_cycle_missions_start_again_with_their_live_robots_and_terminated_ones_stay_ended() {
    let (_, disk) = with_journal(&["r1", "r2", "r3"]);
    let mut sm = restored(&disk, &["r1", "r3"]);
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p1"), "membership from the journal");
    // Heads get their chance to report first.
    let early: Vec<Command> = sm.handle(at(RESTART_S - 1.0), Event::Tick);
    assert!(!early.iter().any(|c| matches!(c, Command::StartMission { .. })), "{early:?}");
    // r2 (of p1) is not back: p1 starts again without it, as its next lineage (a chain of p1
    // cut off with r2 would lose to it wherever they meet).
    let cmds = sm.handle(at(RESTART_S + 0.1), Event::Tick);
    let starts: Vec<(String, Vec<String>, u32)> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::StartMission { start, .. } => {
                Some((start.spec.name.to_string(), start.members.iter().map(|m| m.spec.id.to_string()).collect(), start.lineage))
            }
            _ => None,
        })
        .collect();
    assert_eq!(starts, [("p1".to_string(), vec!["r1".to_string()], 1)], "p1 again with r1, the one alive, lineage 1; never `gone`");
    // The new lineage is on disk before the start goes out.
    let Some(Command::Journal(e)) = cmds.first() else { panic!("{cmds:?}") };
    assert!(e.contains(&JournalEvent::MissionRestarted { mission: "p1".into(), robots: vec!["r1".into()] }));
    assert!(e.iter().any(|e| matches!(e, JournalEvent::MissionDefined { mission, lineage: 1, .. } if mission == "p1")), "{e:?}");
    assert_eq!(sm.durable().assignment.get("r2").map(|m| m.as_str()), Some("p1"), "r2 keeps its place");
    // No second start while that one is out; a failed one is tried again (as the next lineage
    // again: the failed start may have run somewhere), never forgotten.
    assert!(!sm.handle(at(RESTART_S + 1.0), Event::Tick).iter().any(|c| matches!(c, Command::StartMission { .. })));
    sm.handle(at(RESTART_S + 1.5), Event::MissionStarted { mission: "p1".into(), result: Err(Failure::retry("no answer")) });
    assert_eq!(mission_of(&sm, "r1").as_deref(), Some("p1"));
    let again = sm.handle(at(RESTART_S + 1.5 + RESTART_RETRY_S + 0.1), Event::Tick);
    assert!(again.iter().any(|c| matches!(c, Command::StartMission { start, .. } if start.lineage == 2)), "{again:?}");
    // A robot still running the terminated mission is told to leave it.
    let mut t = telemetry("r3", 2, Behaviour::Hold);
    t.mission = Some("gone".into());
    let cmds = sm.handle(at(20.0), Event::Telemetry(Box::new(t)));
    assert!(
        cmds.iter().any(|c| matches!(c, Command::SendToRobot { robot, cmd: RobotCommand::Leave { mission, .. }, .. } if robot == "r3" && mission == "gone")),
        "{cmds:?}"
    );
    // The name of a terminated mission is free again, and a new create of it is not refused.
}

#[test]
fn a_mission_whose_managers_live_is_adopted_not_restarted_and_membership_follows_the_journal() {
    let (_, disk) = with_journal(&["r1", "r2", "r3", "r4"]);
    let mut sm = restored(&disk, &["r1", "r2", "r4"]);
    // r1 says it runs p1: its managers are alive somewhere; nothing is started.
    let mut t = telemetry("r1", 2, Behaviour::Hold);
    t.mission = Some("p1".into());
    sm.handle(at(1.0), Event::Telemetry(Box::new(t)));
    assert!(!sm.handle(at(RESTART_S + 1.0), Event::Tick).iter().any(|c| matches!(c, Command::StartMission { .. })));
    // Its head reports it with r4, which the journal does not put there (the operator freed it
    // before central went down): the head is told to let r4 go, r4 stays free.
    let cmds = sm.handle(at(RESTART_S + 2.0), status(*started_view("p1", "central", &["r1".into(), "r2".into(), "r4".into()])));
    assert!(cmds.iter().any(|c| matches!(c, Command::Ctl { mission, ctl, .. } if mission == "p1" && *ctl == left(&["r4"]))), "{cmds:?}");
    assert_eq!(mission_of(&sm, "r4"), None);
    assert_eq!(mission_of(&sm, "r2").as_deref(), Some("p1"));
    assert!(
        !sm.handle(at(RESTART_S + 20.0), Event::Tick).iter().any(|c| matches!(c, Command::StartMission { .. })),
        "a reported mission is never started again"
    );
}

#[test]
fn a_head_that_missed_a_join_before_the_restart_is_told_again() {
    let (_, disk) = with_journal(&["r1", "r2", "r3"]);
    let mut sm = restored(&disk, &["r1", "r2"]);
    // The head never got r2's join (central went down first): its first report lacks r2.
    let cmds = sm.handle(at(RESTART_S - 1.0), status(*started_view("p1", "central", &["r1".into()])));
    let joined: Vec<&str> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::Ctl { mission, ctl: MissionCtl::Joined { member }, .. } if mission == "p1" => Some(member.spec.id.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(joined, ["r2"], "{cmds:?}");
}

#[test]
fn a_member_with_a_state_dir_holds_starting_anew_back_for_a_while_and_one_up_since_before_does_not() {
    let (_, disk) = with_journal(&["r1", "r2", "r3"]);
    // Central restarted at 0.5; r2 has been up for 100 s: it may still
    // replicate p1 — a new lineage of p1 would win over that chain, so p1 starts anew anyway.
    let fleet = |durable: bool| {
        let mut sm = SystemManager::restore("node".into(), at(0.5), disk.clone());
        sm.handle(at(0.5), Event::HostAlive { node: "central".into() });
        for (id, up) in [("r1", 0.2), ("r2", 100.0), ("r3", 0.3)] {
            sm.handle(at(0.5), Event::RobotAlive { id: id.into() });
            sm.handle(at(0.5), Event::RobotRegistered(RobotInfo { durable: durable && id != "r1", ..info(id) }));
            let mut t = telemetry(id, 1, Behaviour::Hold);
            t.t = up;
            sm.handle(at(0.5), Event::Telemetry(Box::new(t)));
        }
        sm
    };
    let starts = |cmds: &[Command]| cmds.iter().filter(|c| matches!(c, Command::StartMission { start, .. } if start.spec.name == "p1")).count();
    let mut sm = fleet(false);
    let cmds = sm.handle(at(RESTART_S + 1.0), Event::Tick);
    assert!(cmds.iter().any(|c| matches!(c, Command::StartMission { start, .. } if start.spec.name == "p1" && start.lineage == 1)), "{cmds:?}");
    // r2, a member of p1, with a state dir: p1 may come back through its chain, from r2's disk;
    // it gets the time to (r3, with one too, is in no mission: it holds nothing back).
    let mut sm = fleet(true);
    for now in [RESTART_S + 1.0, DURABLE_WAIT_S] {
        assert_eq!(starts(&sm.handle(at(now), Event::Tick)), 0, "not while r2 may bring p1 back");
    }
    // It did not: p1 starts anew with r1 and r2 (r2's old chain retires before the new lineage).
    assert_eq!(starts(&sm.handle(at(DURABLE_WAIT_S + 1.0), Event::Tick)), 1);
    // r2 gone and back (a new process with its disk): held again, for a while.
    let mut sm = fleet(true);
    sm.handle(at(RESTART_S + 2.0), Event::RobotGone { id: "r2".into() });
    sm.handle(at(RESTART_S + 3.0), Event::RobotAlive { id: "r2".into() });
    assert_eq!(starts(&sm.handle(at(DURABLE_WAIT_S + 1.0), Event::Tick)), 0);
    assert_eq!(starts(&sm.handle(at(RESTART_S + 3.0 + DURABLE_WAIT_S + 0.1), Event::Tick)), 1);
}

/// After p1 started again without r2 (lineage 1): r2 back rejoins it, and a head of lineage 0
/// that still runs p1 (cut off with r2, say) is told directly, by a chain message only central
/// may send, that a newer lineage runs it.
#[test]
fn a_member_back_rejoins_the_new_lineage_and_a_head_of_the_old_one_is_fenced() {
    let (_, disk) = with_journal(&["r1", "r2", "r3"]);
    let mut sm = restored(&disk, &["r1", "r3"]);
    let cmds = sm.handle(at(RESTART_S + 0.1), Event::Tick);
    assert!(cmds.iter().any(|c| matches!(c, Command::StartMission { start, .. } if start.lineage == 1)), "{cmds:?}");
    let floor = mrmm_proto::chain::lineage_floor(1);
    let mut view = started_view("p1", "central", &["r1".into()]);
    (view.manager.chain_epoch, view.manager.epoch) = (floor, floor + 1);
    sm.handle(at(RESTART_S + 0.5), Event::MissionStarted { mission: "p1".into(), result: Ok(view) });
    // The old lineage's head, r2's host, reports p1 at chain epoch 7: fenced, not believed.
    let mut old = *started_view("p1", "r2", &["r2".into()]);
    old.manager.chain_epoch = 7;
    let cmds = sm.handle(at(RESTART_S + 1.0), status(old));
    let fence: Vec<(&str, &mrmm_proto::ChainEnvelope)> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::Chain { to, envelope } => Some((to.as_str(), envelope.as_ref())),
            _ => None,
        })
        .collect();
    assert!(
        matches!(fence.as_slice(), [("r2", e)] if e.from == "central" && e.mission == "p1" && e.msg == mrmm_proto::chain::Msg::Stale { promised: floor, last: (floor, 0) }),
        "{cmds:?}"
    );
    assert!(sm.missions.get("p1").and_then(|r| r.view.as_ref()).is_some_and(|v| v.manager.chain_epoch == floor), "the fenced report changed nothing");
    // r2 back: p1's head (of the new lineage) takes it.
    sm.handle(at(RESTART_S + 2.0), Event::RobotAlive { id: "r2".into() });
    let mut cmds = sm.handle(at(RESTART_S + 2.0), Event::RobotRegistered(info("r2")));
    cmds.extend(sm.handle(at(RESTART_S + 2.1), Event::Tick));
    assert!(
        cmds.iter().any(|c| matches!(c, Command::Ctl { mission, ctl: MissionCtl::Joined { member }, .. } if mission == "p1" && member.spec.id == "r2")),
        "{cmds:?}"
    );
}

/// A robot moved on before its first mission let it go (p1 → p2 while p1 has no head, then
/// p2 → none) is held by both releases, on disk too: after a restart of central both missions
/// are told again to let it go, not only the last (system sim, seed 7743: p1 kept r4 for good).
#[test]
fn every_release_still_owed_survives_a_restart() {
    let (mut sm, mut disk) = with_journal(&["r1", "r2", "r3", "r4"]);
    let body = format!(r#"{{"name": "p2", "recipe": "patrol", "robots": ["r3"], {WAYPOINTS}}}"#);
    drive_journaled(&mut sm, &mut disk, at(3.0), Event::Operator { req: Req::Query(4), request: Request::Create(decode(&body)) });
    drive_journaled(&mut sm, &mut disk, at(3.5), Event::MissionStarted { mission: "p2".into(), result: Ok(started_view("p2", "central", &["r3".into()])) });
    for (to, req) in [(r#""p2""#, 5), ("null", 6)] {
        let body = format!(r#"{{"robot": "r2", "to": {to}}}"#);
        let cmds = drive_journaled(&mut sm, &mut disk, at(4.0), Event::Operator { req: Req::Query(req), request: Request::Move(decode(&body)) });
        assert!(cmds.iter().any(|c| matches!(c, Command::Reply { result: Ok(_), .. })), "{cmds:?}");
    }
    let owed: Vec<(&str, &str)> = disk.releasing.iter().map(|(r, m)| (r.as_str(), m.as_str())).collect();
    assert_eq!(owed, [("r2", "p1"), ("r2", "p2")], "both releases on disk");
    let mut sm = SystemManager::restore("node".into(), at(0.0), disk.clone());
    let cmds = sm.handle(at(0.0), Event::HostAlive { node: "central".into() });
    let mut told: Vec<&str> = cmds
        .iter()
        .filter_map(|c| match c {
            Command::Ctl { mission, ctl, .. } if *ctl == left(&["r2"]) => Some(mission.as_str()),
            _ => None,
        })
        .collect();
    told.sort_unstable();
    assert_eq!(told, ["p1", "p2"], "{cmds:?}");
    for id in ["r1", "r2", "r3"] {
        sm.handle(at(0.0), Event::RobotAlive { id: id.into() });
        sm.handle(at(0.0), Event::RobotRegistered(info(id)));
        sm.handle(at(0.0), Event::Telemetry(Box::new(telemetry(id, 1, Behaviour::Hold))));
    }
    // A create with r2 waits for both.
    let body = format!(r#"{{"name": "p3", "recipe": "patrol", "robots": ["r2"], {WAYPOINTS}}}"#);
    let cmds = sm.handle(at(ADOPT_S + 1.0), Event::Operator { req: Req::Query(7), request: Request::Create(decode(&body)) });
    assert!(!cmds.iter().any(|c| matches!(c, Command::StartMission { .. })), "{cmds:?}");
}

/// A robot still runs p but no manager of p reports (its chain lost its majority with central):
/// p is left alone a while (its head may yet report), then started anew with that robot too.
#[test]
fn a_mission_robots_run_but_no_manager_reports_is_started_anew_after_a_while() {
    let (_, disk) = with_journal(&["r1", "r2", "r3"]);
    let mut sm = restored(&disk, &["r1", "r2"]);
    let mut t = telemetry("r2", 2, Behaviour::Hold);
    t.mission = Some("p1".into());
    sm.handle(at(1.0), Event::Telemetry(Box::new(t)));
    let starts = |cmds: Vec<Command>| {
        cmds.iter()
            .filter_map(|c| match c {
                Command::StartMission { start, .. } => Some((start.members.iter().map(|m| m.spec.id.to_string()).collect::<Vec<_>>(), start.lineage)),
                _ => None,
            })
            .collect::<Vec<_>>()
    };
    for now in [RESTART_S + 1.0, RUNNING_WAIT_S - 0.5] {
        assert!(starts(sm.handle(at(now), Event::Tick)).is_empty(), "r2 runs p1: its head may yet report");
    }
    assert_eq!(starts(sm.handle(at(RUNNING_WAIT_S + 0.1), Event::Tick)), [(vec!["r1".to_string(), "r2".to_string()], 1)]);
}

/// Issue 50: a pause acknowledged to the operator was held only in memory until the head
/// acknowledged it; a central killed in between came back with the journal saying paused while
/// the mission ran. The journaled definition is now sent again until the head agrees.
#[test]
fn a_pause_acknowledged_before_a_restart_reaches_the_head_after_it() {
    let (mut sm, mut disk) = with_journal(&["r1", "r2", "r3"]);
    let cmds = drive_journaled(&mut sm, &mut disk, at(3.0), Event::Operator { req: Req::Query(9), request: Request::Pause(decode(r#"{"name": "p1"}"#)) });
    assert!(cmds.iter().any(|c| matches!(c, Command::Reply { result: Ok(_), .. })), "acknowledged: {cmds:?}");
    assert!(disk.missions.get("p1").and_then(|d| d.spec.as_ref()).is_some_and(|s| s.paused), "paused on disk");
    // Central dies before the head hears of it, and comes back from its journal.
    let mut sm = restored(&disk, &["r1", "r2"]);
    let mut running = *started_view("p1", "central", &["r1".into(), "r2".into()]);
    // The head runs the mission's parameters, not paused.
    running.params = disk.missions.get("p1").and_then(|d| d.spec.as_ref()).map(|s| s.params.clone()).unwrap_or_default();
    let updates = |cmds: &[Command]| -> Vec<u64> {
        cmds.iter()
            .filter_map(|c| match c {
                Command::Ctl { id, mission, ctl: MissionCtl::Update { spec }, .. } if mission == "p1" && spec.paused => Some(*id),
                _ => None,
            })
            .collect()
    };
    let mut sent = Vec::new();
    let mut t = 1.0;
    while t < 6.0 {
        sent.extend(updates(&sm.handle(at(t), status(running.clone()))));
        sent.extend(updates(&sm.handle(at(t), Event::Tick)));
        t += 0.5;
    }
    assert_eq!(sent.len(), 1, "the pause is sent again, once while it is on its way");
    // The head acknowledges, and runs paused: nothing more is sent.
    sm.handle(at(6.0), Event::CtlDone { id: sent[0], result: Ok(()) });
    let mut paused = running;
    paused.status = MissionStatus::Paused;
    paused.manager.epoch = 2;
    let mut again = 0;
    for k in 0..20 {
        again += updates(&sm.handle(at(6.5 + f64::from(k)), status(paused.clone()))).len();
        again += updates(&sm.handle(at(6.5 + f64::from(k)), Event::Tick)).len();
    }
    assert_eq!(again, 0);
}
