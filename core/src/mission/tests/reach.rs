//! Planning by reach in the mission manager: the reach a member's telemetry reports goes into
//! its next plan request, and a member the plan leaves out is held on its own, outside the
//! team whose barriers the others wait at.

use super::*;
use crate::at;
use mrmm_proto::BatteryState;

#[test]
fn a_member_short_of_reach_is_held_out_of_the_teams_plan() {
    let mut m = MissionManager::new(spec(), "node".into(), vec![robot("a", "ground", 0.0), robot("b", "ground", 5.0), robot("c", "ground", 10.0)]);
    let (epoch, plan) = plan_for(&m.handle(at(0.0), Event::Start));
    m.handle(at(0.0), Event::PlanReady { epoch, plan: Box::new(plan) });
    // c says its battery takes it 3 m more; the planner's request carries it.
    let mut t = tel("c", 10.0, -2.0, 0, 0);
    t.battery = Some(BatteryState { charge: 0.3, charging: false, reach_m: Some(3.0) });
    m.handle(at(1.0), Event::Telemetry(Box::new(t)));
    let cmds = m.handle(at(2.0), Event::Left { ids: vec!["b".into()] });
    let Some(Command::RequestPlan { request, .. }) = cmds.iter().find(|c| matches!(c, Command::RequestPlan { .. })) else { panic!("a replan: {cmds:?}") };
    assert_eq!(request.robots.iter().find(|r| r.id == "c").and_then(|r| r.reach_m), Some(3.0));
    let (epoch, plan) = plan_for(&cmds);
    assert_eq!(plan.held, ["c"]);
    let sent = plans_sent(&m.handle(at(2.0), Event::PlanReady { epoch, plan: Box::new(plan) }));
    // a patrols on its own: its barriers wait for nobody else.
    assert_eq!(sent["a"].members, ["a"]);
    assert!(sent["a"].plan.steps.iter().any(|s| matches!(s, Step::Sync { .. })));
    // c holds where it is, in a team of its own.
    assert_eq!(sent["c"].members, ["c"]);
    assert_eq!(sent["c"].plan.steps, [Step::Stream, Step::Hold { seconds: None }]);
    assert_eq!(sent["c"].epoch, epoch);
    let v = m.view(false);
    assert_eq!(v.held, ["c"]);
    assert_eq!(v.robots, ["a", "c"], "held, c is still a member");
}
