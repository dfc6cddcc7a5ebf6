//! Unit tests of the replica state machine: scripted message exchanges.

use std::collections::BTreeMap;

use mrmm_proto::Time;

use super::*;
use crate::at;

type R = Replica<Vec<u32>>;

fn p() -> Params {
    Params { quarantine: 0.0, ..Params::default() }
}

/// Delivers every message at once, in order, between the given replicas; returns the other commands.
fn settle(nodes: &mut BTreeMap<String, R>, now: Time, from: &str, cmds: Vec<Command<Vec<u32>>>) -> Vec<(String, Command<Vec<u32>>)> {
    let mut queue: Vec<(String, Command<Vec<u32>>)> = cmds.into_iter().map(|c| (from.to_string(), c)).collect();
    let mut out = Vec::new();
    while !queue.is_empty() {
        let (who, c) = queue.remove(0);
        match c {
            Command::Send { to, msg } => {
                if let Some(r) = nodes.get_mut(to.as_str()) {
                    let more = r.handle(now, Event::Recv { from: who.clone().into(), msg });
                    queue.extend(more.into_iter().map(|c| (to.to_string(), c)));
                }
            }
            other => out.push((who, other)),
        }
    }
    out
}

fn three() -> BTreeMap<String, R> {
    ["a", "b", "c", "d"].iter().map(|n| (n.to_string(), R::new(n, p(), at(0.0), at(0.0), 0))).collect()
}

/// Nodes a, b, c, d, all alive to each other, with a leading the chain a → b → c holding [1].
fn created() -> BTreeMap<String, R> {
    let mut n = three();
    alive_all(&mut n);
    let cmds = n.get_mut("a").unwrap().handle(at(0.0), Event::Create { floor: 0, replicas: vec!["b".into(), "c".into()], state: vec![1] });
    settle(&mut n, at(0.0), "a", cmds);
    n
}

fn alive_all(nodes: &mut BTreeMap<String, R>) {
    let names: Vec<String> = nodes.keys().cloned().collect();
    for r in nodes.values_mut() {
        for n in &names {
            r.handle(at(0.0), Event::Alive(n.clone().into()));
        }
    }
}

#[test]
fn create_replicates_and_commits_through_the_tail() {
    let mut n = three();
    alive_all(&mut n);
    let cmds = n.get_mut("a").unwrap().handle(at(0.0), Event::Create { floor: 0, replicas: vec!["b".into(), "c".into()], state: vec![1] });
    assert!(matches!(&cmds[0], Command::Lead { config, .. } if config.epoch == 1 && config.chain == ["a", "b", "c"]));
    let out = settle(&mut n, at(0.0), "a", cmds);
    assert!(out.contains(&("a".to_string(), Command::Committed { epoch: 1, seq: 0 })), "{out:?}");
    assert_eq!(n["c"].state(), Some(&vec![1]));
    let cmds = n.get_mut("a").unwrap().handle(at(0.1), Event::Propose(vec![1, 2]));
    let out = settle(&mut n, at(0.1), "a", cmds);
    assert!(out.contains(&("a".to_string(), Command::Committed { epoch: 1, seq: 1 })));
    assert_eq!(n["b"].state(), Some(&vec![1, 2]));
    assert_eq!(n["d"].state(), None);
}

#[test]
fn first_live_successor_takes_over_with_the_next_epoch_and_repairs() {
    let mut n = created();
    n.remove("a");
    // c hears first: it must wait for b, its predecessor.
    assert!(n.get_mut("c").unwrap().handle(at(1.0), Event::Gone("a".into())).is_empty());
    let cmds = n.get_mut("b").unwrap().handle(at(1.0), Event::Gone("a".into()));
    let out = settle(&mut n, at(1.0), "b", cmds);
    assert!(
        out.iter()
            .any(|(w, c)| w == "b" && matches!(c, Command::Lead { config, state } if config.epoch == 2 && config.chain == ["b", "c"] && state == &vec![1])),
        "{out:?}"
    );
    assert!(n["b"].is_head());
    // Once its chain holds the state, the head fills the chain up from the pool.
    n.get_mut("b").unwrap().handle(at(1.0), Event::Pool { nodes: vec!["a".into(), "c".into(), "d".into()], k: 2 });
    let cmds = n.get_mut("b").unwrap().handle(at(2.0), Event::Tick);
    settle(&mut n, at(2.0), "b", cmds);
    assert_eq!(n["b"].config().map(|c| c.chain.clone()), Some(vec!["b".into(), "c".into(), "d".into()]));
    assert_eq!(n["d"].state(), Some(&vec![1]));
}

#[test]
fn an_old_head_is_fenced_and_steps_down() {
    let mut n = created();
    // a is cut off; b takes over with c.
    let old = n.remove("a").unwrap();
    let cmds = n.get_mut("b").unwrap().handle(at(1.0), Event::Gone("a".into()));
    settle(&mut n, at(1.0), "b", cmds);
    n.insert("a".into(), old);
    // The old head proposes: b refuses the old epoch, a learns of a newer state and steps down.
    let cmds = n.get_mut("a").unwrap().handle(at(2.0), Event::Propose(vec![1, 9]));
    let out = settle(&mut n, at(2.0), "a", cmds);
    assert!(out.contains(&("a".to_string(), Command::StepDown)), "{out:?}");
    assert!(!out.iter().any(|(w, c)| w == "a" && matches!(c, Command::Committed { .. })));
    assert!(!n["a"].is_head());
    assert!(n["b"].is_head());
    assert_eq!(n["c"].state(), Some(&vec![1]));
}

#[test]
fn a_lone_replica_cannot_take_over() {
    let mut n = created();
    // b is cut from everyone: its votes go nowhere.
    let b = n.get_mut("b").unwrap();
    b.handle(at(1.0), Event::Gone("a".into()));
    let cmds = b.handle(at(1.0), Event::Gone("c".into()));
    assert!(cmds.iter().all(|c| matches!(c, Command::Send { msg: Msg::Vote { .. }, .. })));
    assert!(!n["b"].is_head());
}

#[test]
fn votes_need_an_up_to_date_candidate_and_one_per_epoch() {
    let mut v = R::new("v", p(), at(0.0), at(0.0), 0);
    let prop = |e: u64| Config { epoch: e, chain: vec!["x".into(), "v".into()] };
    let vote = |e: u64, last: Version| Msg::Vote { proposal: prop(e), base: vec!["x".into(), "v".into()], last };
    // No state and a member of the candidate's chain: a restarted node does not vote...
    let three = Msg::Vote { proposal: prop(3), base: vec!["x".into(), "v".into(), "w".into()], last: (1, 4) };
    let out = v.clone().handle(at(0.0), Event::Recv { from: "x".into(), msg: three });
    assert!(matches!(out[0], Command::Send { msg: Msg::Refuse { .. }, .. }));
    let by_replica = Msg::Vote { proposal: prop(3), base: vec!["x".into(), "v".into()], last: (1, 4) };
    let out = v.clone().handle(at(0.0), Event::Recv { from: "w".into(), msg: by_replica });
    assert!(matches!(out[0], Command::Send { msg: Msg::Refuse { .. }, .. }), "w is not the head of the chain of two");
    // ... except for the head of a chain of two: no other configuration can exist without it.
    let out = v.clone().handle(at(0.0), Event::Recv { from: "x".into(), msg: vote(3, (1, 4)) });
    assert!(matches!(out.last(), Some(Command::Send { msg: Msg::Grant { .. }, .. })));
    // With state: one vote per epoch, never backwards, never for an older state.
    v.handle(
        at(0.0),
        Event::Recv { from: "h".into(), msg: Msg::Update { config: Config { epoch: 1, chain: vec!["h".into(), "v".into()] }, seq: 4, state: vec![1] } },
    );
    let grant = |out: &Vec<Command<Vec<u32>>>| matches!(out.last(), Some(Command::Send { msg: Msg::Grant { .. }, .. }));
    assert!(grant(&v.handle(at(0.0), Event::Recv { from: "x".into(), msg: vote(3, (1, 4)) })));
    assert!(grant(&v.handle(at(0.0), Event::Recv { from: "x".into(), msg: vote(3, (1, 4)) })), "the same candidate again");
    assert!(!grant(&v.handle(at(0.0), Event::Recv { from: "y".into(), msg: vote(3, (1, 4)) })));
    assert!(!grant(&v.handle(at(0.0), Event::Recv { from: "y".into(), msg: vote(2, (1, 4)) })));
    assert!(!grant(&v.handle(at(0.0), Event::Recv { from: "y".into(), msg: vote(4, (1, 3)) })));
    assert!(grant(&v.handle(at(0.0), Event::Recv { from: "y".into(), msg: vote(4, (1, 4)) })));
}

#[test]
fn quarantine_blocks_votes_of_a_fresh_process() {
    let mut v = R::new("v", Params::default(), at(10.0), at(10.5), 0);
    let msg = Msg::Vote { proposal: Config { epoch: 1, chain: vec!["x".into(), "v".into()] }, base: vec!["x".into()], last: (0, 0) };
    let out = v.handle(at(10.5), Event::Recv { from: "x".into(), msg: msg.clone() });
    assert!(matches!(out[0], Command::Send { msg: Msg::Refuse { .. }, .. }));
    let out = v.handle(at(12.5), Event::Recv { from: "x".into(), msg });
    assert!(matches!(out[0], Command::Send { msg: Msg::Grant { epoch: 1 }, .. }));
}

#[test]
fn ending_reaches_the_tail_and_retires_everyone() {
    let mut n = created();
    let cmds = n.get_mut("a").unwrap().handle(at(1.0), Event::End);
    let out = settle(&mut n, at(1.0), "a", cmds);
    for who in ["a", "b", "c"] {
        assert!(out.contains(&(who.to_string(), Command::Retired)), "{who}: {out:?}");
    }
}

#[test]
fn refused_for_an_older_state_a_candidate_keeps_it_unless_its_chain_is_outdated() {
    let update = |e: u64, seq: u64| Msg::Update { config: Config { epoch: e, chain: vec!["h".into(), "c".into(), "d".into()] }, seq, state: vec![1] };
    let stand = |c: &mut R| {
        c.handle(at(0.0), Event::Recv { from: "h".into(), msg: update(1, 2) });
        c.handle(at(0.0), Event::Gone("h".into()));
        assert!(matches!(c.role(), Role::Candidate { .. }));
    };
    // Same epoch, the head has more: follow, keep the state (the head needs this vote).
    let mut c = R::new("c", p(), at(0.0), at(0.0), 0);
    stand(&mut c);
    let out = c.handle(at(0.1), Event::Recv { from: "h".into(), msg: Msg::Refuse { epoch: 2, promised: 2, last: (1, 5) } });
    assert!(!out.contains(&Command::Retired));
    assert_eq!((c.role(), c.version()), (&Role::Follower, (1, 2)));
    // A newer epoch exists: this chain is outdated, its state must not count any more.
    let mut c = R::new("c", p(), at(0.0), at(0.0), 0);
    stand(&mut c);
    let out = c.handle(at(0.1), Event::Recv { from: "x".into(), msg: Msg::Refuse { epoch: 2, promised: 7, last: (6, 0) } });
    assert!(out.contains(&Command::Retired));
    assert_eq!(c.state(), None);
}

#[test]
fn beats_carry_no_state_once_the_chain_holds_it_and_a_node_that_lost_it_gets_it_again() {
    let mut n = created();
    let beat = |n: &mut BTreeMap<String, R>, now: Time| n.get_mut("a").unwrap().handle(now, Event::Tick);
    // Committed through the tail: the next heartbeat has no state.
    let cmds = beat(&mut n, at(1.0));
    assert!(matches!(cmds.as_slice(), [Command::Send { msg: Msg::Beat { seq: 0, .. }, .. }]), "{cmds:?}");
    settle(&mut n, at(1.0), "a", cmds);
    // c restarts without memory: on the next beat it says so and gets the state back.
    n.insert("c".into(), R::new("c", p(), at(1.5), at(1.5), 0));
    let cmds = beat(&mut n, at(2.0));
    let mut sent = Vec::new();
    let mut queue: Vec<(String, Command<Vec<u32>>)> = cmds.into_iter().map(|c| ("a".to_string(), c)).collect();
    while let Some((who, c)) = queue.pop() {
        if let Command::Send { to, msg } = c {
            sent.push(msg.describe());
            let more = n.get_mut(to.as_str()).map(|r| r.handle(at(2.0), Event::Recv { from: who.as_str().into(), msg })).unwrap_or_default();
            queue.extend(more.into_iter().map(|c| (to.to_string(), c)));
        }
    }
    assert!(sent.iter().any(|m| m.starts_with("behind")) && sent.iter().filter(|m| m.starts_with("update")).count() >= 2, "{sent:?}");
    assert_eq!(n["c"].state(), Some(&vec![1]));
}

#[test]
fn a_durable_replica_left_out_of_a_newer_chain_stands_less_and_less_often() {
    let mut n = created();
    // c (it keeps its state on disk) is cut off; a repairs its chain without it.
    let c = n.remove("c").unwrap().durable();
    let cmds = n.get_mut("a").unwrap().handle(at(1.0), Event::Gone("c".into()));
    settle(&mut n, at(1.0), "a", cmds);
    assert_eq!(n["a"].config().map(|c| c.chain.clone()), Some(vec!["a".into(), "b".into()]));
    n.insert("c".into(), c);
    // Standing as c: it hears no head, stands, and learns of the newer chain.
    let stands = |n: &mut BTreeMap<String, R>, t: f64| {
        let cmds = n.get_mut("c").unwrap().handle(at(t), Event::Tick);
        let voted = cmds.iter().any(|c| matches!(c, Command::Send { msg: Msg::Vote { .. }, .. }));
        settle(n, at(t), "c", cmds);
        voted
    };
    let silence = p().silence * 2.0; // c is third in its chain
    assert!(stands(&mut n, silence + 0.1), "a replica that hears no head stands");
    assert_eq!(n["c"].passed_over(), 1);
    assert!(!n["c"].leads() && n["a"].is_head(), "the up-to-date rule keeps it from winning");
    // Then twice as long, four times as long, ... up to 2^PASSED_OVER_MAX.
    let mut t = silence + 0.1;
    for k in 1..=PASSED_OVER_MAX + 2 {
        let wait = silence * f64::from(1u32 << k.min(PASSED_OVER_MAX));
        assert!(!stands(&mut n, t + wait - 0.2), "passed over {k} times: not before {wait} s");
        assert!(stands(&mut n, t + wait + 0.1), "passed over {k} times: after {wait} s");
        t += wait + 0.1;
    }
    assert_eq!(n["c"].passed_over(), PASSED_OVER_MAX + 3);
    // Taken back into the chain: the head's update clears it.
    n.get_mut("a").unwrap().handle(at(t), Event::Alive("c".into()));
    n.get_mut("a").unwrap().handle(at(t), Event::Pool { nodes: vec!["c".into()], k: 2 });
    let cmds = n.get_mut("a").unwrap().handle(at(t + 1.0), Event::Tick);
    settle(&mut n, at(t + 1.0), "a", cmds);
    assert_eq!(n["c"].passed_over(), 0, "{:?}", n["c"].config());
}

/// A mission started anew is its next lineage: the first epoch is the lineage's floor, above
/// anything the old chain reached.
#[test]
fn a_new_lineage_starts_at_its_floor() {
    let floor = mrmm_proto::chain::lineage_floor(1);
    let mut r: Registry<Vec<u32>> = Registry::new("a", p(), at(0.0));
    let out = r.create(at(0.0), "m", vec![], vec![1], floor);
    assert!(matches!(&out[0], Command::Lead { config, .. } if config.epoch == floor), "{out:?}");
    // A node that promised more than the floor (it never does in practice) still goes above it.
    let mut r: Registry<Vec<u32>> = Registry::new("a", p(), at(0.0));
    let _ = r.receive(
        at(0.0),
        "m",
        "b".into(),
        Msg::Vote { proposal: Config { epoch: floor + 7, chain: vec!["b".into(), "a".into()] }, base: vec!["b".into()], last: (1, 0) },
    );
    assert_eq!(r.replica("m").map(|x| x.promised()), Some(floor + 7));
    let _ = r.discard(at(0.1), "m");
    let out = r.create(at(0.2), "m", vec![], vec![1], floor);
    assert!(matches!(&out[0], Command::Lead { config, .. } if config.epoch == floor + 8), "{out:?}");
}

/// The head of a replaced lineage, told by central (a `Stale` of the new lineage's floor), steps
/// down and forgets the mission — even on a durable node, which keeps its state when only a newer
/// chain of its own lineage passed it over.
#[test]
fn a_head_of_an_older_lineage_told_of_a_newer_one_retires_even_when_durable() {
    let floor = mrmm_proto::chain::lineage_floor(1);
    let fence = Msg::Stale { promised: floor, last: (floor, 0) };
    for durable in [false, true] {
        let mut r: Registry<Vec<u32>> =
            if durable { Registry::restore("a", p(), at(0.0), at(0.0), std::iter::empty()) } else { Registry::new("a", p(), at(0.0)) };
        let _ = r.create(at(0.0), "m", vec![], vec![1], 0);
        assert!(r.replica("m").is_some_and(|x| x.leads()));
        let out = r.receive(at(0.5), "m", "central".into(), fence.clone());
        assert!(out.contains(&Command::StepDown) && out.contains(&Command::Retired), "durable {durable}: {out:?}");
        assert!(r.replica("m").is_none(), "durable {durable}: the old lineage's replica is gone");
        // Within its own lineage a durable head told of a newer chain keeps its state and follows.
        let mut r: Registry<Vec<u32>> = Registry::restore("a", p(), at(0.0), at(0.0), std::iter::empty());
        let _ = r.create(at(0.0), "m", vec![], vec![1], 0);
        let out = r.receive(at(0.5), "m", "b".into(), Msg::Stale { promised: 9, last: (9, 0) });
        assert!(out.contains(&Command::StepDown) && !out.contains(&Command::Retired), "{out:?}");
        assert!(r.replica("m").is_some_and(|x| x.state().is_some()));
    }
}

/// A node where the old lineage ended answers a vote of that lineage with the end, but not a
/// vote of a newer lineage: the mission started anew is not the ended chain's to end.
#[test]
fn an_ended_chain_does_not_end_a_newer_lineage() {
    let floor = mrmm_proto::chain::lineage_floor(1);
    let mut r: Registry<Vec<u32>> = Registry::new("a", p(), at(0.0));
    let _ = r.create(at(0.0), "m", vec![], vec![1], 0);
    let _ = r.handle(at(0.1), "m", Event::End);
    assert!(r.replica("m").is_none() && r.tomb("m").is_some_and(|t| t.ended));
    let vote = |epoch: u64| Msg::Vote { proposal: Config { epoch, chain: vec!["b".into(), "a".into()] }, base: vec!["b".into(), "a".into()], last: (epoch, 0) };
    let ends = |out: &[Command<Vec<u32>>]| out.iter().any(|c| matches!(c, Command::Send { msg: Msg::End { .. }, .. }));
    assert!(ends(&r.receive(at(0.2), "m", "b".into(), vote(5))), "a straggler of the ended lineage is told to end");
    let out = r.receive(at(0.3), "m", "b".into(), vote(floor + 1));
    assert!(!ends(&out), "a newer lineage was told to end: {out:?}");
    // A replica still ending its lineage refuses a newer lineage's candidate instead.
    let mut r: Registry<Vec<u32>> = Registry::new("a", p(), at(0.0));
    let _ = r.create(at(0.0), "m", vec!["c".into()], vec![1], 0);
    let _ = r.handle(at(0.1), "m", Event::End);
    assert!(r.replica("m").is_some(), "still ending: c has not acknowledged");
    assert!(ends(&r.receive(at(0.2), "m", "b".into(), vote(5))));
    let out = r.receive(at(0.3), "m", "b".into(), vote(floor + 1));
    assert!(!ends(&out) && out.iter().any(|c| matches!(c, Command::Send { msg: Msg::Refuse { .. }, .. })), "{out:?}");
}

/// A late update or beat of the chain that ended on a node does not bring the value back there
/// (its replica could stand and revive the ended mission); one of a value of that name created
/// since, with a newer epoch, is taken.
#[test]
fn a_late_update_of_an_ended_chain_does_not_revive_it() {
    let mut r: Registry<Vec<u32>> = Registry::new("a", p(), at(0.0));
    let cfg = |epoch: u64| Config { epoch, chain: vec!["b".into(), "a".into()] };
    let _ = r.receive(at(0.0), "m", "b".into(), Msg::Update { config: cfg(3), seq: 0, state: vec![1] });
    let epoch = r.replica("m").and_then(|x| x.config()).map(|c| c.epoch);
    assert_eq!(epoch, Some(3), "a replica of b's chain");
    let _ = r.receive(at(0.1), "m", "b".into(), Msg::End { epoch: 3 });
    assert!(r.replica("m").is_none() && r.tomb("m").is_some_and(|t| t.ended && t.promised >= 3));
    for late in [Msg::Update { config: cfg(3), seq: 4, state: vec![1, 2] }, Msg::Beat { config: cfg(3), seq: 4 }] {
        let out = r.receive(at(0.2), "m", "b".into(), late);
        assert!(r.replica("m").is_none(), "revived by a straggler");
        assert!(matches!(out.as_slice(), [Command::Send { msg: Msg::Decline { epoch: 3 }, .. }]), "{out:?}");
    }
    let _ = r.receive(at(0.3), "m", "c".into(), Msg::Update { config: Config { epoch: 9, chain: vec!["c".into(), "a".into()] }, seq: 0, state: vec![7] });
    assert!(r.replica("m").is_some(), "a newer chain of that name is joined");
}

#[test]
fn a_head_whose_chain_lost_its_memory_says_how_long_it_could_not_commit() {
    let mut n = created();
    assert_eq!(n["a"].uncommitted_for(at(0.5)), None, "everything is committed");
    // A change is committed at once when the chain is there.
    let cmds = n.get_mut("a").unwrap().handle(at(1.0), Event::Propose(vec![1, 2]));
    settle(&mut n, at(1.0), "a", cmds);
    assert_eq!(n["a"].uncommitted_for(at(1.0)), None);
    // b and c restart without their disks: blank, they refuse to vote as members of the chain
    // they held, so a's repair never wins, and nothing it proposes commits again.
    for x in ["b", "c"] {
        n.get_mut("a").unwrap().handle(at(2.0), Event::Gone(x.into()));
        n.insert(x.to_string(), R::new(x, p(), at(2.5), at(2.5), 0));
    }
    let names: Vec<String> = n.keys().cloned().collect();
    for r in n.values_mut() {
        for x in &names {
            r.handle(at(2.5), Event::Alive(x.clone().into()));
        }
    }
    let cmds = n.get_mut("a").unwrap().handle(at(3.0), Event::Propose(vec![1, 2, 3]));
    settle(&mut n, at(3.0), "a", cmds);
    let mut t = 3.0;
    while t < 30.0 {
        t += 0.25;
        let cmds = n.get_mut("a").unwrap().handle(at(t), Event::Tick);
        settle(&mut n, at(t), "a", cmds);
    }
    assert!(n["a"].leads(), "{:?}", n["a"].role());
    let stuck = n["a"].uncommitted_for(at(t)).expect("a head that cannot commit says so");
    assert!((stuck - (t - 2.0)).abs() < 1e-9, "uncommitted for {stuck} s at {t} s: not since b went (2 s)");
    assert_eq!(n["b"].state(), None, "{:?}", n["b"].role());
}
