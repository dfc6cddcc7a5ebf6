use std::collections::BTreeMap;
use std::sync::Arc;

use mrmm_maps::graph::{Edge, Vertex};
use mrmm_maps::{NavGraph, Point};
use mrmm_proto::RobotId;

use super::*;
use crate::at;

/// A graph of two-way lanes between points.
fn graph(points: &[(f64, f64)], lanes: &[(u32, u32)]) -> NavGraph {
    let vertices = points.iter().enumerate().map(|(i, &(x, y))| Vertex { charger: false, name: format!("v{i}"), at: Point::new(x, y) }).collect();
    let mut edges = Vec::new();
    for &(a, b) in lanes {
        let length = Point::new(points[a as usize].0, points[a as usize].1).dist(Point::new(points[b as usize].0, points[b as usize].1));
        edges.push(Edge { from: a, to: b, length, passing: false });
        edges.push(Edge { from: b, to: a, length, passing: false });
    }
    NavGraph { vertices, edges }
}

/// A corridor 0 – 1 – 2, 2 m a lane, with a pocket 3 off its middle.
fn corridor_with_pocket() -> Traffic {
    let g = graph(&[(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (2.0, 2.0)], &[(0, 1), (1, 2), (1, 3)]);
    Traffic::new(Arc::new(Layout::new(&g, 0.6)), Params::default())
}

fn id(s: &str) -> RobotId {
    RobotId::from(s)
}

/// What a driver knows of its robot: its route, the position it last reached, the one it may
/// drive to.
type Driven = (Vec<u32>, Option<usize>, Option<usize>);

/// Plays the robots' drivers: each follows its latest route, one granted vertex at a time, in
/// turn; checks after each step that no resource (or two in conflict) is held twice. Returns the
/// commands seen and whether every robot reached the end of its route.
fn drive(t: &mut Traffic, first: Vec<Command>, steps: usize) -> (Vec<Command>, bool) {
    let mut seen = first.clone();
    let mut routes: BTreeMap<RobotId, Driven> = BTreeMap::new();
    let mut pending = first;
    let mut now = 0.0;
    for _ in 0..steps {
        for c in std::mem::take(&mut pending) {
            match c {
                Command::Route { robot, route, reached, upto, .. } => {
                    routes.insert(robot, (route, reached, upto));
                }
                Command::Grant { robot, upto, .. } => {
                    if let Some(r) = routes.get_mut(&robot) {
                        r.2 = Some(upto);
                    }
                }
                _ => {}
            }
        }
        let movers: Vec<RobotId> =
            routes.iter().filter(|(_, (_, reached, upto))| upto.is_some_and(|u| reached.is_none_or(|p| u > p))).map(|(k, _)| k.clone()).collect();
        if movers.is_empty() && routes.values().all(|(route, reached, _)| *reached == Some(route.len() - 1)) {
            return (seen, true);
        }
        now += 1.0;
        for robot in movers {
            let (route, reached, _) = routes.get_mut(&robot).unwrap();
            let next = reached.map_or(0, |p| p + 1);
            *reached = Some(next);
            let out = t.handle(at(now), Event::Reached { robot: robot.clone(), vertex: route[next] });
            check_exclusive(t);
            seen.extend(out.clone());
            pending.extend(out);
        }
        let out = t.handle(at(now), Event::Tick);
        seen.extend(out.clone());
        pending.extend(out);
    }
    (seen, false)
}

fn check_exclusive(t: &Traffic) {
    for r in 0..t.layout().resources() as u32 {
        let Some(h) = t.holder(r) else { continue };
        for &c in t.layout().conflicts(r) {
            if let Some(o) = t.holder(c) {
                assert_eq!(o, h, "{h} holds {r} and {o} holds {c}, which conflict");
            }
        }
    }
}

#[test]
fn robots_meeting_head_on_pass_by_a_pocket() {
    let mut t = corridor_with_pocket();
    let mut first = t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    first.extend(t.handle(at(1.0), Event::Route { robot: id("b"), route: vec![2, 1, 0] }));
    let (seen, done) = drive(&mut t, first, 50);
    assert!(done, "both got through: {seen:?}");
    // b asked last: it made way, into the pocket and back.
    let aside: Vec<_> = seen.iter().filter(|c| matches!(c, Command::Route { why: Why::Deadlock, .. })).collect();
    assert_eq!(aside.len(), 1, "{seen:?}");
    assert!(matches!(aside[0], Command::Route { robot, route, .. } if robot == &id("b") && route.contains(&3)), "{aside:?}");
}

#[test]
fn robots_meeting_head_on_far_from_the_pocket_back_off_to_it() {
    // A corridor cut into 1 m segments, 0 – 1 – … – 11, with a pocket 12 off vertex 1: where
    // they meet, the pocket is eight segments back for one of them.
    let mut points: Vec<(f64, f64)> = (0..12).map(|i| (f64::from(i), 0.0)).collect();
    points.push((1.0, 1.0));
    let mut lanes: Vec<(u32, u32)> = (1..12).map(|i| (i - 1, i)).collect();
    lanes.push((1, 12));
    let mut t = Traffic::new(Arc::new(Layout::new(&graph(&points, &lanes), 0.6)), Params::default());
    let mut first = t.handle(at(0.0), Event::Route { robot: id("a"), route: (0..12).collect() });
    first.extend(t.handle(at(1.0), Event::Route { robot: id("b"), route: (0..12).rev().collect() }));
    let (seen, done) = drive(&mut t, first, 200);
    assert!(done, "both got through: {seen:?}");
    assert!(!seen.iter().any(|c| matches!(c, Command::Blocked { .. })), "{seen:?}");
}

#[test]
fn a_queue_behind_robots_facing_each_other_backs_off_from_its_far_end() {
    // A corridor 0 – 1 – … – 5, 2 m a lane, with a pocket 6 off vertex 3. a (at 3) and b (at 4)
    // face each other; b's goal is the pocket, so a must back off, but c waits behind a and d
    // behind c. Only d is free to make room, then c, then a: b gets through, and they go on.
    let points = [(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (6.0, 0.0), (8.0, 0.0), (10.0, 0.0), (6.0, 2.0)];
    let g = graph(&points, &[(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (3, 6)]);
    let mut t = Traffic::new(Arc::new(Layout::new(&g, 0.6)), Params::default());
    let mut first = Vec::new();
    for (robot, route) in [("a", vec![3, 4, 5]), ("b", vec![4, 3, 6]), ("c", vec![2, 3, 4]), ("d", vec![1, 2, 3])] {
        first.extend(t.handle(at(0.0), Event::Route { robot: id(robot), route }));
    }
    let (seen, done) = drive(&mut t, first, 200);
    assert!(done, "all got through: {seen:?}");
    // (b may be pushed a hop back first, while d still drives up: `push.rs`.)
    let aside: Vec<&RobotId> = seen
        .iter()
        .filter_map(|c| if let Command::Route { robot, why: Why::Deadlock, .. } = c { Some(robot) } else { None })
        .filter(|r| *r != &id("b"))
        .collect();
    assert_eq!(aside, [&id("d"), &id("c"), &id("a")], "the queue's far end first");
}

/// A lane's start is let go once its robot is the clearance past it (more where another lane
/// leaves at a sharp angle), never on a lane too short to gain from it.
#[test]
fn how_far_along_a_lane_its_start_is_let_go() {
    // 0 – 1 – 2 along x, 3 m lanes; from 1 a lane to 3 at 30° off the lane to 2; 4 a metre from 2.
    let at30 = (3.0 + 3.0 * 30f64.to_radians().cos(), 3.0 * 30f64.to_radians().sin());
    let g = graph(&[(0.0, 0.0), (3.0, 0.0), (6.0, 0.0), at30, (7.0, 0.0)], &[(0, 1), (1, 2), (1, 3), (2, 4)]);
    let layout = Layout::new(&g, 0.6);
    let near = |got: Option<f64>, want: f64| got.is_some_and(|d| (d - want).abs() < 1e-9);
    assert!(near(layout.release_after(0, 1), 0.6 + layout::RELEASE_MARGIN_M), "a straight lane: the clearance");
    assert!(near(layout.release_after(1, 2), 0.6 / 0.5 + layout::RELEASE_MARGIN_M), "the lane to 3 at 30°: clearance / sin 30°");
    assert!(near(layout.release_after(2, 1), 0.6 + layout::RELEASE_MARGIN_M), "the lane to 4 goes straight back: no nearer");
    assert_eq!(layout.release_after(2, 4), None, "1 m: too short");
}

/// A robot following another closes up to the vertex the one ahead left, once that one says it
/// is clear of it — not before, and not onto the lane it still drives.
#[test]
fn a_follower_closes_up_to_the_vertex_the_robot_ahead_left() {
    let g = graph(&[(0.0, 0.0), (3.0, 0.0), (6.0, 0.0), (9.0, 0.0)], &[(0, 1), (1, 2), (2, 3)]);
    let mut t = Traffic::new(Arc::new(Layout::new(&g, 0.6)), Params::default());
    t.handle(at(0.0), Event::Restore { robot: id("a"), route: vec![1], reached: Some(0), granted: 0 });
    t.handle(at(0.0), Event::Restore { robot: id("b"), route: vec![0], reached: Some(0), granted: 0 });
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![1, 2, 3] });
    let out = t.handle(at(0.1), Event::Route { robot: id("b"), route: vec![0, 1, 2, 3] });
    assert!(!out.iter().any(|c| matches!(c, Command::Grant { robot, .. } if robot == &id("b"))), "a holds 1: {out:?}");
    // Said of a vertex it did not last reach, or by a robot standing: nothing.
    assert!(t.handle(at(0.2), Event::Left { robot: id("a"), vertex: 2 }).is_empty());
    assert!(t.handle(at(0.2), Event::Left { robot: id("b"), vertex: 0 }).is_empty());
    let out = t.handle(at(1.0), Event::Left { robot: id("a"), vertex: 1 });
    assert!(matches!(&out[..], [Command::Grant { robot, upto: 1, vertex: 1, .. }] if robot == &id("b")), "up to 1, not onto a's lane: {out:?}");
    check_exclusive(&t);
    // a reaches 2: the lane behind it is let go, and b may drive on to 2 once a left it too.
    let out = t.handle(at(2.0), Event::Reached { robot: id("a"), vertex: 2 });
    assert!(!out.iter().any(|c| matches!(c, Command::Grant { robot, upto: 2, .. } if robot == &id("b"))), "{out:?}");
    t.handle(at(2.5), Event::Reached { robot: id("b"), vertex: 1 });
    let out = t.handle(at(3.0), Event::Left { robot: id("a"), vertex: 2 });
    assert!(out.iter().any(|c| matches!(c, Command::Grant { robot, upto: 2, .. } if robot == &id("b"))), "{out:?}");
    check_exclusive(&t);
}

#[test]
fn with_nowhere_to_go_robots_are_reported_blocked() {
    // A bare corridor: no pocket, no way round.
    let g = graph(&[(0.0, 0.0), (2.0, 0.0), (4.0, 0.0)], &[(0, 1), (1, 2)]);
    let mut t = Traffic::new(Arc::new(Layout::new(&g, 0.6)), Params::default());
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    t.handle(at(0.0), Event::Route { robot: id("b"), route: vec![2, 1, 0] });
    let mut out = t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    out.extend(t.handle(at(0.0), Event::Reached { robot: id("b"), vertex: 2 }));
    // One of them got the middle; the other waits. Moving on, they face each other.
    let first = if t.holder(1) == Some(&id("a")) { ("a", 1, "b") } else { ("b", 1, "a") };
    out.extend(t.handle(at(1.0), Event::Reached { robot: id(first.0), vertex: first.1 }));
    assert!(out.iter().any(|c| matches!(c, Command::Blocked { .. })), "{out:?}");
    check_exclusive(&t);
}

#[test]
fn crossing_lanes_without_a_vertex_conflict() {
    // Two lanes crossing in an X, their ends far apart.
    let g = graph(&[(-3.0, 0.0), (3.0, 0.0), (0.0, -3.0), (0.0, 3.0)], &[(0, 1), (2, 3)]);
    let layout = Layout::new(&g, 0.6);
    let (l01, l23) = (layout.lane(0, 1).unwrap(), layout.lane(2, 3).unwrap());
    assert!(layout.conflicts(l01).contains(&l23));
    let mut t = Traffic::new(Arc::new(layout), Params::default());
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1] });
    t.handle(at(0.0), Event::Route { robot: id("b"), route: vec![2, 3] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    t.handle(at(0.0), Event::Reached { robot: id("b"), vertex: 2 });
    let (a, b) = (t.route(&id("a")).unwrap().1, t.route(&id("b")).unwrap().1);
    assert_eq!((a, b), (Some(1), Some(0)), "a drives across, b waits at its end");
    t.handle(at(1.0), Event::Reached { robot: id("a"), vertex: 1 });
    assert_eq!(t.route(&id("b")).unwrap().1, Some(1), "b goes once a is across");
}

#[test]
fn vertices_closer_than_the_clearance_are_held_together() {
    let g = graph(&[(0.0, 0.0), (0.4, 0.0), (5.0, 0.0)], &[(0, 2), (1, 2)]);
    let layout = Layout::new(&g, 0.6);
    assert!(layout.conflicts(0).contains(&1));
    assert!(!layout.conflicts(0).contains(&2));
}

#[test]
fn bad_routes_are_refused_and_change_nothing() {
    let mut t = corridor_with_pocket();
    for (route, says) in [
        (vec![], "empty"),
        (vec![0, 2], "no lane leads from vertex 0 to 2"),
        (vec![0, 9], "vertex 9 is not on the map"),
        (vec![1; MAX_ROUTE + 1].iter().enumerate().map(|(i, _)| (i % 2) as u32).collect(), "at most"),
    ] {
        let out = t.handle(at(0.0), Event::Route { robot: id("a"), route });
        assert!(matches!(&out[..], [Command::Refused { why, .. }] if why.contains(says)), "{says}: {out:?}");
    }
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    // It stands at 0 (granted on to 1): a route from 2 is nowhere it will be.
    let out = t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![2, 1] });
    assert!(matches!(&out[..], [Command::Refused { why, .. }] if why.contains("starts at vertex 2")), "{out:?}");
    assert_eq!(t.route(&id("a")).unwrap().0, &[0, 1]);
}

#[test]
fn reports_of_vertices_not_granted_are_ignored() {
    let mut t = corridor_with_pocket();
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    t.handle(at(0.0), Event::Route { robot: id("b"), route: vec![3, 1] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    t.handle(at(0.0), Event::Reached { robot: id("b"), vertex: 3 });
    // b claims it reached 1 without a grant, and a vertex off its route: nothing changes.
    let held = t.held(&id("b"));
    t.handle(at(1.0), Event::Reached { robot: id("b"), vertex: 2 });
    t.handle(at(1.0), Event::Reached { robot: id("nobody"), vertex: 2 });
    assert_eq!(t.held(&id("b")), held);
    check_exclusive(&t);
}

#[test]
fn a_lost_robot_keeps_where_it_stood_until_removed() {
    let mut t = corridor_with_pocket();
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![1, 2] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 1 });
    assert_eq!(t.route(&id("a")).unwrap().1, Some(1), "granted on to 2");
    t.handle(at(0.5), Event::Lost { robot: id("a") });
    // Lost while it may have started the hop: it keeps both ends and the lane.
    assert!(t.held(&id("a")).contains(&1) && t.held(&id("a")).contains(&2));
    t.handle(at(1.0), Event::Route { robot: id("b"), route: vec![0, 1] });
    t.handle(at(1.0), Event::Reached { robot: id("b"), vertex: 0 });
    assert_eq!(t.route(&id("b")).unwrap().1, Some(0), "b waits for the lost robot's vertex");
    t.handle(at(2.0), Event::Remove { robot: id("a") });
    assert_eq!(t.route(&id("b")).unwrap().1, Some(1), "b goes once it is removed");
}

#[test]
fn a_new_route_is_joined_behind_what_was_granted() {
    let mut t = corridor_with_pocket();
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    assert_eq!(t.route(&id("a")).unwrap().1, Some(2));
    // Still at 0, granted to 2: a route from 1 is joined at 1, the grant kept to 1 (the pocket
    // is let go as granted).
    let out = t.handle(at(1.0), Event::Route { robot: id("a"), route: vec![1, 3] });
    let Some(Command::Route { route, reached, upto, .. }) = out.first() else { panic!("{out:?}") };
    assert_eq!((route.as_slice(), *reached), (&[0, 1, 2, 1, 3][..], Some(0)), "drives back from 2 along its way");
    assert_eq!(*upto, Some(2));
    // Asked from where it stands: joined at once.
    let mut t = corridor_with_pocket();
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 1 });
    let out = t.handle(at(1.0), Event::Route { robot: id("a"), route: vec![1, 3] });
    assert!(matches!(&out[0], Command::Route { route, reached: Some(0), .. } if route == &vec![1, 3]), "{out:?}");
}

#[test]
fn a_parked_robot_makes_way_after_a_while() {
    let mut t = corridor_with_pocket();
    // b parks at 1, the junction, which a must cross.
    t.handle(at(0.0), Event::Route { robot: id("b"), route: vec![1] });
    t.handle(at(0.0), Event::Reached { robot: id("b"), vertex: 1 });
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    let out = t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    assert!(!out.iter().any(|c| matches!(c, Command::Route { .. })), "not at once: {out:?}");
    let out = t.handle(at(Params::default().yield_after + 0.1), Event::Tick);
    assert!(out.iter().any(|c| matches!(c, Command::Route { robot, why: Why::Yield, route, .. } if robot == &id("b") && route == &vec![1, 3, 1])), "{out:?}");
}

#[test]
fn routes_joined_again_and_again_stay_bounded() {
    // A robot that never moves asks, again and again, for a long route starting at the end of
    // the one it has: joined behind its grant each time, it would grow without bound.
    let mut t = corridor_with_pocket();
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    let long: Vec<u32> = (0..MAX_ROUTE).map(|i| (i % 2) as u32).collect();
    let mut refused = 0;
    for k in 0..5 {
        let end = *t.route(&id("a")).unwrap().0.last().unwrap();
        let route: Vec<u32> = if end == 0 { long.clone() } else { long.iter().map(|v| 1 - v).collect() };
        let out = t.handle(at(f64::from(k)), Event::Route { robot: id("a"), route });
        refused += out.iter().filter(|c| matches!(c, Command::Refused { why, .. } if why.contains("at most"))).count();
        assert!(t.route(&id("a")).unwrap().0.len() <= MAX_ROUTE);
    }
    assert!(refused > 0);
}

/// The conflicts found through the buckets are exactly those of comparing every pair, on random
/// graphs of short and long lanes (long ones make the buckets wider than the clearance).
#[test]
fn conflicts_found_through_buckets_are_those_of_every_pair() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(50);
    for case in 0..40 {
        let span = if case % 2 == 0 { 20.0 } else { 3_000.0 };
        let n = rng.gen_range(2..40);
        let points: Vec<(f64, f64)> = (0..n).map(|_| (rng.gen_range(0.0..span), rng.gen_range(0.0..span))).collect();
        let lanes: Vec<(u32, u32)> = (0..n).map(|_| (rng.gen_range(0..n as u32), rng.gen_range(0..n as u32))).filter(|(a, b)| a != b).collect();
        let g = graph(&points, &lanes);
        let layout = Layout::new(&g, 0.6);
        for r in 0..layout.resources() as Res {
            let mut want: Vec<Res> = (0..layout.resources() as Res).filter(|&o| o != r && layout.brute_conflict(r, o)).collect();
            want.sort_unstable();
            let mut got = layout.conflicts(r).to_vec();
            got.sort_unstable();
            assert_eq!(got, want, "case {case}, resource {r}");
        }
    }
}

/// Issue 50: a 2 km graph of long diagonal lanes filed every lane under each bucket of its
/// bounding box (10⁸–10⁹ entries). Now the samples along its lanes are bounded.
#[test]
fn a_large_graph_of_long_diagonal_lanes_is_laid_out_in_bounded_memory() {
    let n = 400u32;
    // Points on two opposite sides of a 2 km square, every one linked to four across.
    let points: Vec<(f64, f64)> = (0..n).map(|i| if i % 2 == 0 { (0.0, 5.0 * f64::from(i)) } else { (2_000.0, 2_000.0 - 5.0 * f64::from(i)) }).collect();
    let lanes: Vec<(u32, u32)> = (0..n).flat_map(|i| (1..=4).map(move |k| (i, (i + 2 * k + 1) % n))).collect();
    let layout = Layout::new(&graph(&points, &lanes), 0.6);
    let samples = layout.samples();
    assert!(samples as f64 <= layout::MAX_SAMPLES + 2.0 * layout.resources() as f64, "{samples} samples");
    // Long lanes crossing in the middle conflict.
    let l = layout.lane(0, 3).expect("lane");
    assert!(!layout.conflicts(l).is_empty());
}

/// A corridor of four lanes (0 – 1 – 2 – 3 – 4, 1 m apart), locked by direction: with robot a
/// inside it driving east, robot b at the east end is not granted its way in westwards, though
/// the lane it asks for is free; a robot following a eastwards is. Without the lock b is granted.
#[test]
fn a_corridor_is_held_for_one_direction_at_a_time() {
    let g = graph(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (4.0, 0.0), (-1.0, 0.0)], &[(0, 1), (1, 2), (2, 3), (3, 4), (5, 0)]);
    let layout = Arc::new(Layout::new(&g, 0.6));
    assert_eq!(layout.corridor(0, 1).map(|(c, _)| c), layout.corridor(3, 4).map(|(c, _)| c), "one corridor");
    assert_eq!(layout.corridor(0, 1).map(|(_, f)| f), layout.corridor(3, 2).map(|(_, f)| !f), "ways opposite");
    for locked in [true, false] {
        let mut t = Traffic::new(layout.clone(), Params { corridors: locked, ..Params::default() });
        // a stands at 1, inside, granted on east; b stands at 4, the east end, wants west to 2.
        t.handle(at(0.0), Event::Restore { robot: id("a"), route: vec![1, 2, 3], reached: Some(0), granted: 0 });
        t.handle(at(0.0), Event::Restore { robot: id("b"), route: vec![4], reached: Some(0), granted: 0 });
        t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![1, 2] });
        let out = t.handle(at(0.1), Event::Route { robot: id("b"), route: vec![4, 3] });
        let b_granted = out.iter().any(|c| matches!(c, Command::Grant { robot, .. } | Command::Route { robot, upto: Some(1), .. } if robot == &id("b")));
        assert_eq!(b_granted, !locked, "locked {locked}: {out:?}");
        check_exclusive(&t);
    }
    // Two robots driving apart in the corridor do not hold each other up: a at 2 goes east to 3,
    // b at 1 goes west to 0 (a is behind b's way, b behind a's).
    let mut t = Traffic::new(layout, Params { corridors: true, ..Params::default() });
    t.handle(at(0.0), Event::Restore { robot: id("a"), route: vec![2], reached: Some(0), granted: 0 });
    t.handle(at(0.0), Event::Restore { robot: id("b"), route: vec![1], reached: Some(0), granted: 0 });
    let mut out = t.handle(at(0.1), Event::Route { robot: id("a"), route: vec![2, 3] });
    out.extend(t.handle(at(0.2), Event::Route { robot: id("b"), route: vec![1, 0] }));
    for who in ["a", "b"] {
        assert!(
            out.iter().any(|c| matches!(c, Command::Grant { robot, .. } | Command::Route { robot, upto: Some(1), .. } if robot == &id(who))),
            "{who}: {out:?}"
        );
    }
}

/// A route names a vertex by the map's name where that name is its alone (a VDA 5050 vehicle's
/// node id): not a name two vertices share, an empty one, one of `v<digits>` (names by index)
/// or one longer than a route carries.
#[test]
fn a_route_names_a_vertex_by_a_name_of_its_own() {
    let mut g = graph(&[(0.0, 0.0), (2.0, 0.0), (4.0, 0.0), (6.0, 0.0), (8.0, 0.0), (10.0, 0.0)], &[(0, 1), (1, 2), (2, 3), (3, 4), (4, 5)]);
    let long = "n".repeat(mrmm_proto::traffic::MAX_VERTEX_NAME + 1);
    for (v, name) in [(0, "dock"), (1, "lobby"), (2, "lobby"), (3, ""), (4, long.as_str()), (5, "v3")] {
        g.vertices[v].name = name.to_string();
    }
    let layout = Layout::new(&g, 0.6);
    let names: Vec<String> = (0..6).map(|v| layout.route_vertex(v).node_id()).collect();
    assert_eq!(names, ["dock", "v1", "v2", "v3", "v4", "v5"]);
    assert_eq!(layout.route_vertex(5).name, None, "\"v3\" would be vertex 3's node");
    assert_eq!(layout.route_vertex(0).x, 0.0);
}

/// A robot docked at a charger is a parking spot: parked in another's way it does not make way
/// (the robot waiting for it is reported blocked by it), where the same robot undocked does.
#[test]
fn a_robot_docked_at_a_charger_does_not_make_way() {
    let mut t = corridor_with_pocket();
    // b charges at 1, the junction, which a must cross.
    t.handle(at(0.0), Event::Route { robot: id("b"), route: vec![1] });
    t.handle(at(0.0), Event::Reached { robot: id("b"), vertex: 1 });
    t.handle(at(0.0), Event::Dock { robot: id("b"), on: true });
    assert!(t.is_docked(&id("b")));
    t.handle(at(0.0), Event::Route { robot: id("a"), route: vec![0, 1, 2] });
    t.handle(at(0.0), Event::Reached { robot: id("a"), vertex: 0 });
    let after = Params::default().yield_after + 0.1;
    let out = t.handle(at(after), Event::Tick);
    assert!(!out.iter().any(|c| matches!(c, Command::Route { robot, .. } if robot == &id("b"))), "a docked robot sent aside: {out:?}");
    assert!(out.iter().any(|c| matches!(c, Command::Blocked { robot, by } if robot == &id("a") && by == &vec![id("b")])), "{out:?}");
    let out = t.handle(at(after + 0.1), Event::Dock { robot: id("b"), on: false });
    assert!(out.iter().any(|c| matches!(c, Command::Route { robot, why: Why::Yield, .. } if robot == &id("b"))), "undocked, it makes way: {out:?}");
}
