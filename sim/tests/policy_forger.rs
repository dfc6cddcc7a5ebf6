//! The forger against the one policy (`mrmm_proto::policy::POLICY`): for every act and every
//! role the table refuses a node that is nothing to what it speaks of, a forger of that role
//! tries it on the production machine or edge that judges it — the robot, the mission host,
//! central's system manager, the viewer — and must be refused, with nothing of the machine
//! changed. Acts judged by a node's driver (central's access control, the planner service, a
//! map fetch) are named with the real-process test that tries them; a new act must be given one
//! or the other.

use mrmm_core::body::Limits;
use mrmm_core::central::system;
use mrmm_core::mission::host;
use mrmm_core::robot::viewers;
use mrmm_core::robot::{self, Robot, RobotSetup};
use mrmm_core::{ask, observer};
use mrmm_proto::edge::{Incoming, Refused};
use mrmm_proto::policy::{self, Act, Relation, POLICY};
use mrmm_proto::{
    self as proto, ChainEnvelope, Key, MissionCtl, MissionSpecWire, MissionStart, MissionView, Pose, Role, Sender, SyncArrival, SyncRelease, Time,
};

/// Acts judged by a node's driver, and the real-process test that tries each as a forger.
const DRIVER_JUDGED: [(Act, &str); 4] = [
    (Act::Command, "tests/python_client.rs (a robot certificate's command is dropped by central's access control); tests/security.rs"),
    (Act::PlanRequest, "tests/authorization.rs, plan_requests_for_maps_central_never_published_cost_central_nothing (and the planner service's role check)"),
    (Act::MapManifest, "tests/authorization.rs, a_holder_serving_bad_map_chunks_is_passed_over (a fetch takes a manifest from central only)"),
    (Act::Report, "mrmm-core system::tests::missions::a_report_cannot_claim_robots_nor_speak_for_another_manager (needs a mission central knows)"),
];

const VICTIM: &str = "r1";

fn json(v: &impl serde::Serialize) -> Vec<u8> {
    serde_json::to_vec(v).expect("json")
}

fn robot_machine() -> Robot {
    Robot::new(RobotSetup::sim(VICTIM, "ground", Limits { max_speed: 1.0, max_turn_rate: 1.0 }, Pose::default()))
}

fn refused<T: std::fmt::Debug>(r: Result<T, Refused>) -> Result<(), String> {
    match r {
        Err(Refused::NotEntitled { .. }) => Ok(()),
        other => Err(format!("taken: {other:?}")),
    }
}

/// The forger `from` (nothing to what it speaks of) tries `act`; `Err` if it was taken.
fn forge(act: Act, from: &Sender) -> Result<(), String> {
    let heard = |key: Key, payload: Vec<u8>| (key.to_string(), payload);
    match act {
        Act::Telemetry => {
            let (key, payload) =
                heard(Key::RobotTelemetry(VICTIM.into()), proto::encode_telemetry(&proto::Telemetry::resting(VICTIM, 0.0)).expect("telemetry"));
            let m = Incoming { key: &key, payload: &payload, put: true, from: Some(from) };
            refused(system::ingress(m))?;
            refused(host::ingress(m))?;
            refused(observer::observe(m))
        }
        Act::Arrival | Act::Release => {
            let (key, payload) = match act {
                Act::Arrival => {
                    heard(Key::TeamSync { team: "m".into(), point: 0, round: 0 }, json(&SyncArrival { robot: VICTIM.into(), epoch: 1, point: 0, round: 0 }))
                }
                _ => {
                    heard(Key::TeamRelease { team: "m".into(), point: 0, round: 0 }, json(&SyncRelease { leader: VICTIM.into(), epoch: 1, point: 0, round: 0 }))
                }
            };
            let m = Incoming { key: &key, payload: &payload, put: true, from: Some(from) };
            refused(robot_machine().ingress(m))?;
            refused(observer::observe(m))
        }
        Act::Status => {
            // A status naming the victim its manager: the viewer refuses it at its edge, central
            // in its system manager.
            let view = MissionView::running("m", "patrol", VICTIM, 1, &[VICTIM]);
            let (key, payload) = heard(Key::MissionStatus("m".into()), json(&view));
            refused(observer::observe(Incoming { key: &key, payload: &payload, put: true, from: Some(from) }))?;
            let mut sm = system::SystemManager::new("central".into(), Time::from_secs(-10.0));
            let out = sm.handle(Time::ZERO, system::Event::MissionStatus { view: Box::new(view), from: from.clone() });
            match out.as_slice() {
                [system::Command::Refused(Refused::NotEntitled { .. })] => Ok(()),
                other => Err(format!("taken by central: {other:?}")),
            }
        }
        Act::Adopt => {
            // A mission nobody created, the forger its head, an idle robot in it.
            let mut sm = system::SystemManager::new("central".into(), Time::from_secs(-10.0));
            sm.handle(Time::ZERO, system::Event::HostAlive { node: from.id.as_str().into() });
            let mut view = MissionView::running("evil", "patrol", &from.id, 1, &[&from.id, VICTIM]);
            view.manager.chain = vec![from.id.as_str().into()];
            let cmds = sm.handle(Time::from_secs(1.0), system::Event::MissionStatus { view: Box::new(view), from: from.clone() });
            let taken = cmds.iter().any(|c| !matches!(c, system::Command::Refused(_)));
            if taken || sm.status(Time::from_secs(1.0)).missions > 0 {
                return Err(format!("adopted: {cmds:?}"));
            }
            Ok(())
        }
        Act::Chain => {
            let env = ChainEnvelope { mission: "m".into(), from: from.id.as_str().into(), msg: proto::chain::Msg::Grant { epoch: 1 } };
            let (key, payload) = heard(Key::HostChain("h".into()), json(&env));
            match host::ingress(Incoming { key: &key, payload: &payload, put: true, from: Some(from) }) {
                Err(Refused::NotEntitled { .. }) => Ok(()),
                Ok(ev) => {
                    // A robot the host knows nothing of is first held back a few seconds while its
                    // telemetry may come to say it runs the mission; then refused.
                    let mut h = host::HostCore::new("h", Default::default(), Time::ZERO);
                    let held = h.handle(Time::ZERO, ev.clone());
                    let out = h.handle(Time::from_secs(60.0), ev);
                    let refused = |cmds: &[host::Command]| cmds.iter().any(|c| matches!(c, host::Command::Refused(_)));
                    match (held.is_empty() && refused(&out)) || refused(&held) {
                        true => Ok(()),
                        false => Err(format!("taken by the host: {held:?} then {out:?}")),
                    }
                }
                Err(e) => Err(format!("refused for another reason: {e:?}")),
            }
        }
        Act::Start | Act::Control => {
            let mut h = host::HostCore::new("h", Default::default(), Time::ZERO);
            let ev = match act {
                Act::Start => {
                    let spec = MissionSpecWire {
                        name: "m".into(),
                        recipe_name: "patrol".into(),
                        recipe_xml: mrmm_planner::recipe::bank("patrol").unwrap_or_default().to_string(),
                        planner: "patrol".into(),
                        params: Default::default(),
                        replicas: 2,
                        map: None,
                        paused: false,
                    };
                    host::Event::Start { query: 1, start: Box::new(MissionStart { spec, members: vec![], anew: false, lineage: 0 }), from: from.clone() }
                }
                _ => host::Event::Ctl { query: 1, mission: "m".into(), ctl: MissionCtl::Terminate, from: from.clone() },
            };
            let out = h.handle(Time::ZERO, ev);
            match out.iter().any(|c| matches!(c, host::Command::Refused(_))) && h.heads().next().is_none() {
                true => Ok(()),
                false => Err(format!("taken by the host: {out:?}")),
            }
        }
        Act::Order | Act::Plan => {
            let cmd = match act {
                Act::Order => proto::RobotCommand::Goto { x: 5.0, y: 5.0, via: vec![], map: None },
                _ => proto::RobotCommand::Plan(Box::new(proto::PlanAssignment {
                    handover: None,
                    mission: "m".into(),
                    epoch: 1,
                    team: "m".into(),
                    subteam: "m/ground".into(),
                    members: vec![VICTIM.into()],
                    plan: proto::RobotPlan {
                        robot: VICTIM.into(),
                        robot_type: "ground".into(),
                        slot: 0,
                        steps: vec![proto::Step::Navigate { x: 4.0, y: 0.0, speed: None }],
                        team: String::new(),
                    },
                    managers: vec![],
                    barrier: proto::BarrierMode::Mesh,
                    scopes: vec![],
                    map: None,
                })),
            };
            let mut r = robot_machine();
            // Central reachable: no idle robot takes a plan from a stranger then.
            r.handle(Time::ZERO, robot::Event::CentralAlive(true));
            let out = r.handle(Time::ZERO, robot::Event::Command { cmd, from: from.clone() });
            match out.as_slice() {
                [robot::Command::Refuse(_)] => Ok(()),
                other => Err(format!("taken by the robot: {other:?}")),
            }
        }
        Act::PlanAnswer => match ask::Answerer::Planner.admits(from) {
            false => Ok(()),
            true => Err("a plan answer admitted".into()),
        },
        Act::Advice => {
            let a = proto::AdviceEvent::Withdrawn { id: "x".into(), reason: "forged".into() };
            let (key, payload) = heard(Key::AgentAdviceLive, json(&a));
            refused(observer::observe(Incoming { key: &key, payload: &payload, put: true, from: Some(from) }))
        }
        Act::Viewer => match viewers::Viewers::new(2000).heard(0, from.clone()) {
            viewers::Heard::NotAViewer => Ok(()),
            other => Err(format!("a viewer: {other:?}")),
        },
        Act::TrafficReport => {
            let report = proto::TrafficReport { robot: VICTIM.into(), seq: 1, x: 0.0, y: 0.0, goal: None, held: None, docked: false };
            let (key, payload) = heard(Key::TrafficReport { map: "a".repeat(64), robot: VICTIM.into() }, json(&report));
            refused(mrmm_core::central::ingress(Incoming { key: &key, payload: &payload, put: true, from: Some(from) }))
        }
        Act::TrafficOrder => {
            let (key, payload) = heard(Key::TrafficOrder { map: "a".repeat(64), robot: VICTIM.into() }, json(&proto::TrafficOrder::Free));
            refused(robot_machine().ingress(Incoming { key: &key, payload: &payload, put: true, from: Some(from) }))
        }
        Act::Report | Act::Command | Act::PlanRequest | Act::MapManifest | Act::Read | Act::MapChunk => Ok(()),
    }
}

#[test]
fn every_act_the_policy_refuses_a_stranger_is_refused_by_the_machine_that_judges_it() {
    let mut tried = Vec::new();
    for row in &POLICY {
        if let Some((_, test)) = DRIVER_JUDGED.iter().find(|(a, _)| *a == row.act) {
            println!("{:?}: judged by a driver, tried by {test}", row.act);
            continue;
        }
        for role in Role::ALL {
            if policy::allows(row.act, role, Relation::Stranger) {
                continue;
            }
            let from = Sender::new(role, "r9");
            let case = format!("{:?} by {role} r9", row.act);
            forge(row.act, &from).unwrap_or_else(|e| panic!("{case} ({}): {e}", row.what));
            tried.push(case);
        }
    }
    println!("{} forgeries refused: {tried:?}", tried.len());
    // Every act the table restricts was tried here or by a named driver test.
    for row in POLICY.iter().filter(|r| Role::ALL.iter().any(|&role| !policy::allows(r.act, role, Relation::Stranger))) {
        let here = tried.iter().any(|c| c.starts_with(&format!("{:?} by", row.act)));
        let elsewhere = DRIVER_JUDGED.iter().any(|(a, _)| *a == row.act);
        assert!(here || elsewhere, "{:?} is restricted but no forger tries it", row.act);
    }
}
