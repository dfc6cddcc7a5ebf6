//! Unit tests of plan execution and of both barrier modes.

use super::*;
use crate::at;
use mrmm_proto::{RobotPlan, Time};

fn tick(e: &mut Executor, now: Time, body_idle: bool) -> Vec<Command> {
    e.handle(now, Event::Tick { body_idle })
}

fn exec(steps: Vec<Step>, members: &[&str]) -> Executor {
    exec_as("a", BarrierMode::Mesh, steps, members)
}

fn exec_as(me: &str, barrier: BarrierMode, steps: Vec<Step>, members: &[&str]) -> Executor {
    Executor::new(PlanAssignment {
        handover: None,
        mission: "m".into(),
        epoch: 2,
        team: "m".into(),
        subteam: "m/ground".into(),
        members: members.iter().map(|s| s.into()).collect(),
        plan: RobotPlan { robot: me.into(), robot_type: "ground".into(), slot: 0, steps, team: String::new() },
        managers: vec![],
        barrier,
        scopes: vec![],
        map: None,
    })
}

/// Robot `me` of leaf team `m/<team>` (members `mine`), whose plan also has barriers of the
/// whole mission (members `all`).
fn exec_in_team(me: &str, team: &str, steps: Vec<Step>, mine: &[&str], all: &[&str]) -> Executor {
    let ids = |v: &[&str]| v.iter().map(RobotId::from).collect::<Vec<_>>();
    Executor::new(PlanAssignment {
        handover: None,
        mission: "m".into(),
        epoch: 2,
        team: format!("m/{team}"),
        subteam: format!("m/{team}/ground"),
        members: ids(mine),
        plan: RobotPlan { robot: me.into(), robot_type: "ground".into(), slot: 0, steps, team: team.into() },
        managers: vec![],
        barrier: BarrierMode::Mesh,
        scopes: vec![mrmm_proto::ScopeMembers { team: "m".into(), members: ids(all) }],
        map: None,
    })
}

#[test]
fn a_team_barrier_waits_only_on_its_team_and_a_mission_barrier_on_everyone() {
    let mission = Some(String::new());
    let steps = vec![Step::Sync { point: 0, scope: mission.clone() }, Step::Sync { point: 1, scope: None }, nav(5.0)];
    let mut a = exec_in_team("a", "fast", steps, &["a", "b"], &["a", "b", "c", "d"]);
    let arrival = |r: &str, point: u32| SyncArrival { robot: r.into(), epoch: 2, point, round: 0 };
    // The mission's barrier, the plan's first: the robot faces its next point, then its arrival
    // is published for the mission, not the team.
    assert_eq!(a.handle(at(0.0), Event::Tick { body_idle: true }), vec![Command::Face { x: 5.0, y: 0.0 }]);
    assert!(a.handle(at(0.02), Event::Tick { body_idle: false }).is_empty(), "turning");
    assert_eq!(a.handle(at(0.05), Event::Tick { body_idle: true }), vec![Command::PublishIn("m".into(), arrival("a", 0))]);
    for r in ["b", "c"] {
        a.handle(at(0.1), Event::HeardIn("m".into(), arrival(r, 0)));
    }
    // An arrival of the team's own barrier does not count for the mission's.
    a.handle(at(0.1), Event::Heard(arrival("d", 0)));
    assert!(a.handle(at(0.2), Event::Tick { body_idle: true }).is_empty(), "d of the slow team has not arrived");
    a.handle(at(0.3), Event::HeardIn("m".into(), arrival("d", 0)));
    let out = a.handle(at(0.4), Event::Tick { body_idle: true });
    assert_eq!(out, vec![Command::Publish(arrival("a", 1)), Command::Face { x: 5.0, y: 0.0 }], "past the mission's barrier, at the team's");
    // The team's barrier: b alone completes it; c and d (the other team) are never waited for.
    a.handle(at(0.5), Event::Heard(arrival("b", 1)));
    let out = a.handle(at(0.6), Event::Tick { body_idle: true });
    assert_eq!(out, vec![Command::Navigate { x: 5.0, y: 0.0, then: None, speed: Some(1.0) }]);
    assert_eq!(a.progress().syncs_passed, 2);
    // A member of the other team that is gone no longer holds the mission's barrier up.
    let steps = vec![Step::Sync { point: 0, scope: mission }, nav(1.0)];
    let mut c = exec_in_team("c", "slow", steps, &["c", "d"], &["a", "b", "c", "d"]);
    c.handle(at(0.0), Event::Tick { body_idle: true });
    c.handle(at(0.05), Event::Tick { body_idle: true });
    for r in ["a", "b"] {
        c.handle(at(0.1), Event::HeardIn("m".into(), arrival(r, 0)));
    }
    assert!(c.handle(at(0.2), Event::Tick { body_idle: true }).is_empty());
    c.handle(at(0.3), Event::MemberGone("d".into()));
    assert_eq!(c.handle(at(0.4), Event::Tick { body_idle: true }), vec![Command::Navigate { x: 1.0, y: 0.0, then: None, speed: Some(1.0) }]);
}

fn nav(x: f64) -> Step {
    Step::Navigate { x, y: 0.0, speed: Some(1.0) }
}

#[test]
fn navigates_step_by_step_then_holds_at_the_end() {
    let mut e = exec(vec![Step::Stream, nav(1.0), nav(2.0)], &["a"]);
    // It drives on from the first point to the second: the body may round that corner.
    let onward = Some(Onward { x: 2.0, y: 0.0, speed: Some(1.0) });
    assert_eq!(tick(&mut e, at(0.0), true), vec![Command::Navigate { x: 1.0, y: 0.0, then: onward, speed: Some(1.0) }]);
    assert!(tick(&mut e, at(0.1), false).is_empty(), "still driving");
    assert_eq!(tick(&mut e, at(0.2), true), vec![Command::Navigate { x: 2.0, y: 0.0, then: None, speed: Some(1.0) }]);
    assert_eq!(tick(&mut e, at(0.3), true), vec![Command::Hold]);
    assert!(e.progress().done);
    assert!(tick(&mut e, at(0.4), true).is_empty());
}

/// A point the plan drives on from is rounded; one it stops at (a barrier, a hold, the plan's
/// end, a loop's last round) is not; a loop drives on to its first point.
#[test]
fn the_body_is_told_where_the_plan_drives_on_to() {
    let then = |cmds: Vec<Command>| match cmds.as_slice() {
        [Command::Navigate { then, .. }] => then.map(|o| o.x),
        other => panic!("{other:?}"),
    };
    let steps = vec![nav(1.0), nav(2.0), Step::Loop { to: 0, rounds: Some(2) }];
    let mut e = exec(steps, &["a"]);
    assert_eq!(then(tick(&mut e, at(0.0), true)), Some(2.0));
    assert_eq!(then(tick(&mut e, at(0.1), true)), Some(1.0), "through the loop, first round");
    assert_eq!(then(tick(&mut e, at(0.2), true)), Some(2.0));
    assert_eq!(then(tick(&mut e, at(0.3), true)), None, "the last round ends there");
    let mut e = exec(vec![nav(1.0), Step::Sync { point: 1, scope: None }, nav(2.0)], &["a"]);
    assert_eq!(then(tick(&mut e, at(0.0), true)), None, "a barrier: it stops");
    let mut e = exec(vec![nav(1.0), Step::Hold { seconds: Some(1.0) }, nav(2.0)], &["a"]);
    assert_eq!(then(tick(&mut e, at(0.0), true)), None, "a hold: it stops");
    let mut e = exec(vec![nav(1.0), Step::Stream, nav(2.0)], &["a"]);
    assert_eq!(then(tick(&mut e, at(0.0), true)), Some(2.0), "streaming does not stop it");
}

/// The team leaves its first barrier together: a member that came last announces itself only
/// once it faces its way (a robot comes to its slot from anywhere, up to a U-turn away from it).
/// Later barriers are reached driving the plan's way: arrival is announced at once and the turn
/// at a sync point's corner is made while waiting, as the plan's timing counts it.
#[test]
fn only_the_first_barrier_waits_for_the_turn_before_the_arrival() {
    let steps = vec![Step::Sync { point: 0, scope: None }, nav(1.0), Step::Sync { point: 1, scope: None }, nav(2.0)];
    let mut e = exec(steps, &["a"]);
    assert_eq!(tick(&mut e, at(0.0), true), vec![Command::Face { x: 1.0, y: 0.0 }]);
    for t in [0.05, 0.1, 0.9] {
        assert!(tick(&mut e, at(t), false).is_empty(), "turning at {t}: not yet there");
    }
    assert_eq!(e.progress().syncs_passed, 0);
    let out = tick(&mut e, at(1.0), true);
    assert_eq!(out.first(), Some(&Command::Publish(arrival("a", 0, 0))), "{out:?}");
    assert_eq!(e.progress().syncs_passed, 1);
    assert!(tick(&mut e, at(1.5), false).is_empty(), "driving");
    let out = tick(&mut e, at(2.0), true);
    assert_eq!(out[..2], [Command::Publish(arrival("a", 1, 0)), Command::Face { x: 2.0, y: 0.0 }], "announced and turning at once");
    assert_eq!(e.progress().syncs_passed, 2);
}

#[test]
fn barrier_waits_republishes_and_releases() {
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }, nav(1.0)], &["a", "b"]);
    // At the team's first barrier it turns to face the plan's next point, then says it is there.
    assert_eq!(tick(&mut e, at(0.0), true), vec![Command::Face { x: 1.0, y: 0.0 }]);
    assert!(tick(&mut e, at(0.05), false).is_empty(), "still turning");
    assert_eq!(tick(&mut e, at(0.1), true), vec![Command::Publish(SyncArrival { robot: "a".into(), epoch: 2, point: 0, round: 0 })]);
    assert_eq!(e.progress().waiting, Some((0, 0)));
    assert!(tick(&mut e, at(0.2), true).is_empty());
    assert_eq!(tick(&mut e, at(0.6), true).len(), 1, "re-published while waiting");
    e.handle(at(0.65), Event::Heard(SyncArrival { robot: "b".into(), epoch: 2, point: 0, round: 0 }));
    assert_eq!(tick(&mut e, at(0.7), true), vec![Command::Navigate { x: 1.0, y: 0.0, then: None, speed: Some(1.0) }]);
    let p = e.progress();
    assert_eq!((p.syncs_passed, p.sync_msgs, p.waiting), (1, 2, None));
    assert_eq!(p.sync_wait_s, 0.0, "the first barrier is the formation's");
}

#[test]
fn barrier_wait_is_counted_after_the_formation() {
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }, Step::Sync { point: 1, scope: None }], &["a", "b"]);
    let heard = |e: &mut Executor, t: f64, point: u32| e.handle(at(t), Event::Heard(SyncArrival { robot: "b".into(), epoch: 2, point, round: 0 }));
    tick(&mut e, at(0.0), true);
    heard(&mut e, 2.0, 0);
    tick(&mut e, at(2.0), true);
    tick(&mut e, at(3.0), true);
    heard(&mut e, 3.5, 1);
    tick(&mut e, at(3.7), true);
    let p = e.progress();
    assert_eq!(p.syncs_passed, 2);
    assert!((p.sync_wait_s - 1.7).abs() < 1e-9, "waited at the second barrier from 2.0 to 3.7: {}", p.sync_wait_s);
}

#[test]
fn republication_keeps_its_wall_clock_period_on_a_fast_clock() {
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }], &["a", "b"]).with_time_scale(10.0);
    assert_eq!(tick(&mut e, at(0.0), true).len(), 1, "the arrival");
    assert!(tick(&mut e, at(1.0), true).is_empty(), "0.1 wall seconds later: not yet");
    assert_eq!(tick(&mut e, at(5.0), true).len(), 1, "0.5 wall seconds later: again");
}

#[test]
fn a_long_wait_backs_off_and_a_new_teammate_brings_the_gap_back() {
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }], &["a", "b"]);
    let sent = |e: &mut Executor, from: u32, to: u32| -> Vec<u32> { (from..to).filter(|&t| !tick(e, at(f64::from(t) * 0.1), true).is_empty()).collect() };
    // Arrival at 0, then gaps 0.5, 1, 2, 2, 2 s (tenths of a second).
    assert_eq!(sent(&mut e, 0, 100), [0, 5, 15, 35, 55, 75, 95]);
    // A teammate's token appears: the next one comes within REPUBLISH_S of the last, then backs off again.
    e.handle(at(9.6), Event::MemberAlive("b".into()));
    assert_eq!(sent(&mut e, 100, 200), [100, 110, 130, 150, 170, 190]);
}

#[test]
fn a_teammate_that_missed_our_last_arrival_gets_it_again() {
    let arrival = |robot: &str| SyncArrival { robot: robot.into(), epoch: 2, point: 0, round: 0 };
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }], &["a", "b"]);
    tick(&mut e, at(0.0), true);
    // b's arrival while we wait there ourselves: the normal case, no echo.
    e.handle(at(0.0), Event::Heard(arrival("b")));
    assert_eq!(tick(&mut e, at(0.1), true), vec![Command::Hold], "released: the plan is over");
    // b publishes that arrival again: it is still waiting, it missed ours. We say it again.
    e.handle(at(0.0), Event::Heard(arrival("b")));
    assert_eq!(tick(&mut e, at(0.2), true), vec![Command::Publish(arrival("a"))]);
    e.handle(at(0.0), Event::Heard(arrival("b")));
    assert!(tick(&mut e, at(0.3), true).is_empty(), "at most every REPUBLISH_S");
    assert_eq!(tick(&mut e, at(0.8), true), vec![Command::Publish(arrival("a"))]);
}

#[test]
fn a_lost_teammate_does_not_block() {
    let mut e = exec(vec![Step::Sync { point: 0, scope: None }, Step::Hold { seconds: None }], &["a", "b"]);
    tick(&mut e, at(0.0), true);
    e.handle(at(0.05), Event::MemberGone("b".into()));
    assert_eq!(tick(&mut e, at(0.1), true), vec![Command::Hold]);
}

#[test]
fn loops_count_rounds_and_barriers_are_per_round() {
    let steps = vec![Step::Sync { point: 0, scope: None }, nav(1.0), Step::Sync { point: 1, scope: None }, Step::Loop { to: 1, rounds: Some(2) }];
    let mut e = exec(steps, &["a"]);
    let mut published = Vec::new();
    for i in 0..20 {
        for a in tick(&mut e, at(i as f64), true) {
            if let Command::Publish(s) = a {
                published.push((s.point, s.round));
            }
        }
    }
    assert_eq!(published, [(0, 0), (1, 0), (1, 1)]);
    let p = e.progress();
    assert!(p.done);
    assert_eq!((p.round, p.syncs_passed), (2, 3));
}

#[test]
fn timed_hold_and_endless_loop_of_instant_steps_do_not_spin() {
    let mut e = exec(vec![Step::Hold { seconds: Some(1.0) }, Step::Stream, Step::Loop { to: 1, rounds: None }], &["a"]);
    assert_eq!(tick(&mut e, at(0.0), true), vec![Command::Hold]);
    assert!(tick(&mut e, at(0.5), true).is_empty());
    // Past the hold: an endless loop of instantaneous steps is bounded per tick.
    assert!(tick(&mut e, at(1.5), true).is_empty());
    assert!(e.progress().round > 0);
}

fn arrival(robot: &str, point: u32, round: u32) -> SyncArrival {
    SyncArrival { robot: robot.into(), epoch: 2, point, round }
}

fn release(leader: &str, point: u32, round: u32) -> SyncRelease {
    SyncRelease { leader: leader.into(), epoch: 2, point, round }
}

#[test]
fn the_leader_hears_every_arrival_and_announces_the_release_once() {
    let steps = vec![Step::Sync { point: 0, scope: None }, nav(1.0)];
    let mut a = exec_as("a", BarrierMode::Leader, steps.clone(), &["a", "b", "c"]);
    // Leading: the runtime starts hearing arrivals; its own arrival is not published.
    assert_eq!(tick(&mut a, at(0.0), true), vec![Command::Lead(true), Command::Face { x: 1.0, y: 0.0 }]);
    assert!(tick(&mut a, at(0.05), true).is_empty(), "facing its way: its arrival counts, unpublished");
    assert_eq!(a.progress().waiting, Some((0, 0)));
    assert!(a.handle(at(0.1), Event::Heard(arrival("b", 0, 0))).is_empty(), "c is missing");
    assert_eq!(a.handle(at(0.2), Event::Heard(arrival("c", 0, 0))), vec![Command::Release(release("a", 0, 0))], "at once, not at the next tick");
    assert_eq!(tick(&mut a, at(0.3), true), vec![Command::Navigate { x: 1.0, y: 0.0, then: None, speed: Some(1.0) }]);
    assert_eq!(a.progress().sync_msgs, 1, "the leader sends one message per barrier");
    // b missed the release and asks again: the leader repeats it, at most every REPUBLISH_S.
    assert_eq!(a.handle(at(0.8), Event::Heard(arrival("b", 0, 0))), vec![Command::Release(release("a", 0, 0))]);
    assert!(a.handle(at(0.9), Event::Heard(arrival("b", 0, 0))).is_empty());
    assert!(tick(&mut a, at(1.0), false).is_empty());
    assert_eq!(tick(&mut a, at(1.35), false), vec![Command::Release(release("a", 0, 0))], "due, sent with the next tick");
    assert!(tick(&mut a, at(2.0), false).is_empty(), "once");
}

#[test]
fn a_member_publishes_to_the_leader_waits_for_its_release_and_is_quiet_after() {
    let steps = vec![Step::Sync { point: 0, scope: None }, nav(1.0), Step::Sync { point: 1, scope: None }];
    let mut b = exec_as("b", BarrierMode::Leader, steps, &["a", "b", "c"]);
    assert_eq!(tick(&mut b, at(0.0), true), vec![Command::Face { x: 1.0, y: 0.0 }]);
    assert_eq!(tick(&mut b, at(0.05), true), vec![Command::Publish(arrival("b", 0, 0))], "not leading: no Lead");
    assert!(tick(&mut b, at(0.1), true).is_empty());
    assert_eq!(tick(&mut b, at(0.6), true), vec![Command::Publish(arrival("b", 0, 0))], "re-published while waiting");
    // Arrivals reach a member only when it leads; one that did would count, but c is missing.
    b.handle(at(0.6), Event::Heard(arrival("a", 0, 0)));
    b.handle(at(0.7), Event::Released(release("zz", 0, 0)));
    b.handle(at(0.7), Event::Released(SyncRelease { epoch: 1, ..release("a", 0, 0) }));
    assert!(tick(&mut b, at(0.8), true).is_empty(), "foreign releases release nothing");
    b.handle(at(0.9), Event::Released(release("a", 0, 0)));
    assert_eq!(tick(&mut b, at(1.0), true), vec![Command::Navigate { x: 1.0, y: 0.0, then: None, speed: Some(1.0) }]);
    // Driving to the next barrier, the leader has our arrival: nothing more to say.
    for t in [1.5, 2.0, 3.0] {
        assert!(tick(&mut b, at(t), false).is_empty());
    }
    assert_eq!(tick(&mut b, at(3.1), true), vec![Command::Publish(arrival("b", 1, 0))]);
    b.handle(at(3.2), Event::Released(release("a", 1, 0)));
    assert_eq!(tick(&mut b, at(3.3), true), vec![Command::Hold]);
    assert_eq!(b.progress().sync_msgs, 3);
}

#[test]
fn when_the_leader_dies_the_next_lowest_takes_over_and_learns_every_arrival() {
    let steps = vec![Step::Sync { point: 0, scope: None }, nav(1.0), Step::Sync { point: 1, scope: None }];
    let mut b = exec_as("b", BarrierMode::Leader, steps.clone(), &["a", "b", "c"]);
    let mut c = exec_as("c", BarrierMode::Leader, steps, &["a", "b", "c"]);
    tick(&mut b, at(0.0), true);
    tick(&mut c, at(0.0), true);
    // a released barrier 0; b and c drive on.
    b.handle(at(0.1), Event::Released(release("a", 0, 0)));
    c.handle(at(0.1), Event::Released(release("a", 0, 0)));
    tick(&mut b, at(0.2), true);
    tick(&mut c, at(0.2), true);
    // a dies: b leads. c has not heard from b: it re-sends its furthest arrival until b releases it.
    assert_eq!(b.handle(at(0.3), Event::MemberGone("a".into())), vec![Command::Lead(true), Command::Release(release("b", 0, 0))]);
    assert!(c.handle(at(0.3), Event::MemberGone("a".into())).is_empty());
    assert_eq!(tick(&mut c, at(0.8), false), vec![Command::Publish(arrival("c", 0, 0))]);
    assert!(tick(&mut c, at(0.9), false).is_empty(), "at most every REPUBLISH_S");
    assert_eq!(tick(&mut c, at(1.3), false), vec![Command::Publish(arrival("c", 0, 0))]);
    c.handle(at(1.4), Event::Released(release("b", 0, 0)));
    assert!(tick(&mut c, at(2.0), false).is_empty(), "b has it");
    // Both reach barrier 1; b releases once it hears c.
    assert!(tick(&mut b, at(2.1), true).is_empty(), "b leads: it does not publish its arrival");
    assert_eq!(tick(&mut c, at(2.2), true), vec![Command::Publish(arrival("c", 1, 0))]);
    assert_eq!(b.handle(at(2.3), Event::Heard(arrival("c", 1, 0))), vec![Command::Release(release("b", 1, 0))]);
    c.handle(at(2.4), Event::Released(release("b", 1, 0)));
    assert_eq!(tick(&mut b, at(2.5), true), vec![Command::Hold]);
    assert_eq!(tick(&mut c, at(2.5), true), vec![Command::Hold]);
    // a comes back (with this plan's epoch): it leads again, b stops hearing arrivals.
    assert_eq!(b.handle(at(3.0), Event::MemberAlive("a".into())), vec![Command::Lead(false)]);
}

#[test]
fn a_lone_survivor_leads_and_releases_itself() {
    let mut b = exec_as("b", BarrierMode::Leader, vec![Step::Sync { point: 0, scope: None }, Step::Hold { seconds: None }], &["a", "b"]);
    assert_eq!(tick(&mut b, at(0.0), true), vec![Command::Publish(arrival("b", 0, 0))]);
    assert_eq!(b.handle(at(0.1), Event::MemberGone("a".into())), vec![Command::Lead(true), Command::Release(release("b", 0, 0))]);
    assert_eq!(tick(&mut b, at(0.2), true), vec![Command::Hold]);
}

/// A robot that starts waiting at a barrier faces the plan's next point, following the plan's
/// loop back to its start; before a hold it faces nothing.
#[test]
fn a_robot_waiting_at_a_barrier_faces_where_it_goes_next() {
    let looped = vec![Step::Stream, nav(3.0), Step::Sync { point: 0, scope: None }, Step::Loop { to: 1, rounds: None }];
    let mut e = exec(looped, &["a", "b"]);
    assert_eq!(tick(&mut e, at(0.0), true), vec![Command::Navigate { x: 3.0, y: 0.0, then: None, speed: Some(1.0) }]);
    let out = tick(&mut e, at(0.1), true);
    assert!(out.contains(&Command::Face { x: 3.0, y: 0.0 }), "through the loop: {out:?}");
    let held = vec![Step::Sync { point: 0, scope: None }, Step::Hold { seconds: None }];
    let mut e = exec(held, &["a", "b"]);
    assert!(!tick(&mut e, at(0.0), true).iter().any(|c| matches!(c, Command::Face { .. })), "nowhere to go next");
}

/// A patrol's plan: to the slot, the formation barrier, then a round of two legs with a barrier
/// after each, looped.
fn round_steps() -> Vec<Step> {
    vec![
        nav(0.0),
        Step::Sync { point: 0, scope: None },
        nav(10.0),
        Step::Sync { point: 1, scope: None },
        nav(20.0),
        Step::Sync { point: 2, scope: None },
        Step::Loop { to: 2, rounds: None },
    ]
}

/// Drives `e` through ticks until it waits at a barrier or asks to navigate (the body arriving
/// at once); what it published.
fn run_until_waiting(e: &mut Executor, now: Time) -> Vec<Command> {
    let mut all = Vec::new();
    for k in 0..20 {
        let out = tick(e, now + f64::from(k) * 0.01, true);
        let waiting = e.progress().waiting.is_some() && out.is_empty();
        all.extend(out);
        if waiting {
            break;
        }
    }
    all
}

#[test]
fn a_plan_carried_on_keeps_its_place_and_a_robot_taking_over_starts_on_the_leavers_leg() {
    let handover = Some(mrmm_proto::Handover { planned: 2, step: 3, round: 4 });
    let mut a = exec_as("a", BarrierMode::Mesh, round_steps(), &["a", "b"]);
    // a is past the formation, waiting at barrier 1 of round 0 for b.
    run_until_waiting(&mut a, at(0.0));
    a.handle(at(0.1), Event::Heard(SyncArrival { robot: "b".into(), epoch: 2, point: 0, round: 0 }));
    let out = run_until_waiting(&mut a, at(0.2));
    assert!(out.contains(&Command::Publish(SyncArrival { robot: "a".into(), epoch: 2, point: 1, round: 0 })), "{out:?}");
    let before = a.progress();
    assert_eq!((before.step, before.waiting), (3, Some((1, 0))));

    // b hands its place to c: a carries on under epoch 3, waiting where it was, and says so again.
    let next = PlanAssignment { epoch: 3, members: vec!["a".into(), "c".into()], handover, ..a.assignment.clone() };
    assert!(a.carried_on_by(&next));
    let other_lineage = PlanAssignment { handover: Some(mrmm_proto::Handover { planned: 1, step: 0, round: 0 }), ..next.clone() };
    assert!(!a.carried_on_by(&other_lineage), "a plan of another lineage is a new plan");
    assert!(!a.carried_on_by(&PlanAssignment { handover: None, ..next.clone() }), "a replan is a new plan");
    a.carry_on(next);
    let out = tick(&mut a, at(1.0), true);
    assert_eq!(out.first(), Some(&Command::Publish(SyncArrival { robot: "a".into(), epoch: 3, point: 1, round: 0 })), "its arrival again, under the new epoch");
    let p = a.progress();
    assert_eq!((p.epoch, p.step, p.round, p.syncs_passed, p.sync_msgs), (3, 3, 0, 1, 1));
    assert!(tick(&mut a, at(1.1), true).is_empty(), "c has not arrived");
    a.handle(at(1.2), Event::Heard(SyncArrival { robot: "b".into(), epoch: 3, point: 1, round: 0 }));
    assert!(tick(&mut a, at(1.3), true).is_empty(), "b is no member now");
    a.handle(at(1.4), Event::Heard(SyncArrival { robot: "c".into(), epoch: 3, point: 1, round: 0 }));
    let out = tick(&mut a, at(1.5), true);
    assert!(matches!(out.first(), Some(Command::Navigate { x, .. }) if *x == 20.0), "released by the newcomer: {out:?}");

    // c takes b's plan where b was: step 3 (a barrier) is reached by the leg before it, in b's
    // round, past the formation.
    let plan = RobotPlan { robot: "c".into(), robot_type: "ground".into(), slot: 1, steps: round_steps(), team: String::new() };
    let mut c = Executor::taking_over(PlanAssignment { epoch: 3, members: vec!["a".into(), "c".into()], handover, plan, ..a.assignment.clone() }, 3, 4);
    let p = c.progress();
    assert_eq!((p.step, p.round, p.syncs_passed), (2, 4, 1));
    let out = tick(&mut c, at(0.0), true);
    assert!(matches!(out.as_slice(), [Command::Navigate { x, .. }] if *x == 10.0), "{out:?}");
    let out = tick(&mut c, at(0.1), true);
    assert!(out.contains(&Command::Publish(SyncArrival { robot: "c".into(), epoch: 3, point: 1, round: 4 })), "{out:?}");
    // Still in the formation: it starts at its slot like any member.
    let plan = RobotPlan { robot: "c".into(), robot_type: "ground".into(), slot: 1, steps: round_steps(), team: String::new() };
    let c = Executor::taking_over(PlanAssignment { epoch: 3, members: vec!["a".into(), "c".into()], handover, plan, ..a.assignment.clone() }, 1, 0);
    assert_eq!((c.progress().step, c.progress().syncs_passed), (0, 0));
}
