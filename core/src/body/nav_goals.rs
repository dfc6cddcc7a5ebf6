//! Goals to Nav2's `NavigateToPose` action, without I/O: which goal to send and which to cancel,
//! when to try a refused or failed goal again, and what to report while the robot cannot get
//! anywhere (telemetry's `stuck`, which the advising agent raises at once).

use mrmm_proto::nav::{status, GoalEvent, GoalId};
use mrmm_proto::{Pose, Time};

/// A goal Nav2 rejected or aborted is sent again after this long, seconds (its recoveries may
/// have cleared the way; a new target is sent at once).
pub const RETRY_S: f64 = 5.0;
/// Recovery behaviours Nav2 may run on the way to one goal before the robot is reported as not
/// getting there (it may still make it: the report goes once the goal is reached or replaced).
pub const RECOVERIES_REPORTED: u16 = 3;
/// Longest reason reported (telemetry stays small).
const MAX_REASON: usize = 200;

/// What the link must do.
#[derive(Debug, Clone, PartialEq)]
pub enum NavCommand {
    /// Send a goal at (`x`, `y`) facing `yaw`.
    Send { id: GoalId, x: f64, y: f64, yaw: f64 },
    /// Cancel a goal sent before.
    Cancel(GoalId),
}

#[derive(Debug, Clone, PartialEq)]
struct Active {
    id: GoalId,
    target: (f64, f64),
}

/// The goals of one robot.
#[derive(Debug, Clone)]
pub struct Nav2Goals {
    action: String,
    /// Whether the action server is in the ROS graph (all three services).
    server: bool,
    active: Option<Active>,
    /// Why the robot is not getting to its target, while that lasts.
    stuck: Option<String>,
    /// A target that failed and when it may be tried again.
    retry: Option<((f64, f64), Time)>,
    seed: GoalId,
    count: u64,
    /// The target of a goal that succeeded, until the next tick reports it.
    succeeded: Option<(f64, f64)>,
}

impl Nav2Goals {
    /// `action` names the action in reports; goal ids are `seed` with a counter mixed in.
    pub fn new(action: &str, seed: GoalId) -> Self {
        Nav2Goals { action: action.to_string(), server: false, active: None, stuck: None, retry: None, seed, count: 0, succeeded: None }
    }

    pub fn stuck(&self) -> Option<&str> {
        self.stuck.as_deref()
    }

    /// The action server appeared in the graph or left it (a goal it had is lost with it).
    pub fn set_server(&mut self, up: bool) {
        self.server = up;
        if !up {
            self.active = None;
        }
    }

    /// An answer about goal `id` at wall time `now`; answers about goals no longer active are
    /// ignored (a cancelled goal's result, a late reply).
    pub fn on_event(&mut self, now: Time, id: GoalId, event: GoalEvent) {
        let Some(a) = &self.active else { return };
        if a.id != id {
            return;
        }
        let (x, y) = a.target;
        let failed = match event {
            GoalEvent::Accepted => {
                self.stuck = None;
                None
            }
            GoalEvent::Feedback { recoveries, distance_remaining } => {
                if recoveries >= RECOVERIES_REPORTED {
                    self.stuck = Some(format!(
                        "Nav2 ({}) is recovering on the way to ({x:.2}, {y:.2}): {recoveries} recoveries, {distance_remaining:.1} m left",
                        self.action
                    ));
                }
                None
            }
            GoalEvent::Finished(status::SUCCEEDED) => {
                self.active = None;
                self.succeeded = Some((x, y));
                self.stuck = None;
                None
            }
            GoalEvent::Rejected => Some(format!("Nav2 ({}) rejected the goal to ({x:.2}, {y:.2})", self.action)),
            GoalEvent::Finished(s) => Some(format!("Nav2 ({}) goal to ({x:.2}, {y:.2}) ended {}", self.action, status::name(s))),
            GoalEvent::Failed(why) => Some(format!("Nav2 ({}) goal to ({x:.2}, {y:.2}): {why}", self.action)),
        };
        if let Some(mut why) = failed {
            if why.len() > MAX_REASON {
                let cut = (0..=MAX_REASON).rev().find(|&i| why.is_char_boundary(i)).unwrap_or(0);
                why.truncate(cut);
            }
            self.active = None;
            self.stuck = Some(why);
            self.retry = Some(((x, y), now + RETRY_S));
        }
    }

    /// One tick at `now`: `goal` is where the robot should be going (`None`: hold), `halted`
    /// whether it must not move (stale odometry, no fleet), `from` where it is (the goal faces
    /// away from it). Returns the commands and whether the goal was reached.
    pub fn step(&mut self, now: Time, goal: Option<(f64, f64)>, halted: bool, from: Pose) -> (Vec<NavCommand>, bool) {
        let mut out = Vec::new();
        // Reached, unless a new target came in the meantime (then that one is sent below).
        if self.succeeded.take().is_some_and(|t| goal == Some(t)) {
            return (out, true);
        }
        if let Some(a) = &self.active {
            if halted || goal != Some(a.target) {
                out.push(NavCommand::Cancel(a.id));
                self.active = None;
            }
        }
        let Some((x, y)) = goal else {
            self.stuck = None;
            self.retry = None;
            return (out, false);
        };
        if halted || self.active.is_some() {
            return (out, false);
        }
        if !self.server {
            self.stuck = Some(format!("Nav2 action server {} is not in the ROS graph", self.action));
            return (out, false);
        }
        match self.retry {
            Some((target, at)) if target == (x, y) && now < at => return (out, false),
            Some((target, _)) if target != (x, y) => self.stuck = None,
            _ => {}
        }
        self.count = self.count.wrapping_add(1);
        let mut id = self.seed;
        for (b, c) in id[8..].iter_mut().zip(self.count.to_le_bytes()) {
            *b ^= c;
        }
        let yaw = (y - from.y).atan2(x - from.x);
        out.push(NavCommand::Send { id, x, y, yaw: if yaw.is_finite() { yaw } else { 0.0 } });
        self.active = Some(Active { id, target: (x, y) });
        (out, false)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    /// Goals with the server up and a first goal sent, to (1, 0) at t = 0.
    fn sending(seed: GoalId) -> (Nav2Goals, GoalId) {
        let mut n = Nav2Goals::new("/nav", seed);
        n.set_server(true);
        let a = sent(&n.step(at(0.0), Some((1.0, 0.0)), false, Pose::default()).0).expect("sent");
        (n, a)
    }

    fn sent(cmds: &[NavCommand]) -> Option<GoalId> {
        cmds.iter().find_map(|c| match c {
            NavCommand::Send { id, .. } => Some(*id),
            NavCommand::Cancel(_) => None,
        })
    }

    #[test]
    fn a_goal_is_sent_once_and_reached() {
        let mut n = Nav2Goals::new("/navigate_to_pose", [1; 16]);
        let (cmds, _) = n.step(at(0.0), Some((3.0, 4.0)), false, Pose::default());
        assert!(cmds.is_empty());
        assert!(n.stuck().is_some_and(|s| s.contains("not in the ROS graph")), "no server: reported");
        n.set_server(true);
        let (cmds, _) = n.step(at(0.1), Some((3.0, 4.0)), false, Pose::default());
        let id = sent(&cmds).expect("sent");
        assert!(matches!(cmds[0], NavCommand::Send { x: 3.0, y: 4.0, yaw, .. } if (yaw - 4f64.atan2(3.0)).abs() < 1e-12));
        n.on_event(at(0.2), id, GoalEvent::Accepted);
        assert_eq!(n.stuck(), None);
        assert_eq!(n.step(at(0.3), Some((3.0, 4.0)), false, Pose::default()), (vec![], false), "nothing twice");
        n.on_event(at(5.0), id, GoalEvent::Finished(status::SUCCEEDED));
        assert_eq!(n.step(at(5.1), Some((3.0, 4.0)), false, Pose::default()), (vec![], true));
    }

    #[test]
    fn a_success_does_not_end_a_newer_target() {
        let (mut n, a) = sending([5; 16]);
        n.on_event(at(1.0), a, GoalEvent::Finished(status::SUCCEEDED));
        // A goto lands between the result and the next tick.
        let (cmds, arrived) = n.step(at(1.01), Some((2.0, 2.0)), false, Pose::default());
        assert!(!arrived, "the new target is not reached");
        assert!(matches!(cmds[..], [NavCommand::Send { x: 2.0, y: 2.0, .. }]), "{cmds:?}");
    }

    #[test]
    fn a_new_target_hold_or_halt_cancels_the_goal() {
        let (mut n, a) = sending([2; 16]);
        let (cmds, _) = n.step(at(0.1), Some((2.0, 0.0)), false, Pose::default());
        assert_eq!(cmds[0], NavCommand::Cancel(a));
        let b = sent(&cmds).expect("the new goal");
        assert_ne!(a, b);
        n.on_event(at(0.2), a, GoalEvent::Finished(status::CANCELED));
        assert_eq!(n.stuck(), None, "the cancelled goal's result is not a failure");
        assert_eq!(n.step(at(0.3), Some((2.0, 0.0)), true, Pose::default()).0, vec![NavCommand::Cancel(b)], "halted");
        assert_eq!(n.step(at(0.4), Some((2.0, 0.0)), true, Pose::default()).0, vec![], "nothing while halted");
        let c = sent(&n.step(at(0.5), Some((2.0, 0.0)), false, Pose::default()).0).expect("sent again once the halt is over");
        assert_eq!(n.step(at(0.6), None, false, Pose::default()).0, vec![NavCommand::Cancel(c)], "hold");
    }

    #[test]
    fn rejected_or_aborted_goals_are_reported_and_retried() {
        let (mut n, a) = sending([3; 16]);
        n.on_event(at(0.1), a, GoalEvent::Rejected);
        assert!(n.stuck().is_some_and(|s| s.contains("rejected")));
        assert_eq!(n.step(at(1.0), Some((1.0, 0.0)), false, Pose::default()).0, vec![], "not before the retry");
        let b = sent(&n.step(at(RETRY_S + 0.2), Some((1.0, 0.0)), false, Pose::default()).0).expect("retried");
        n.on_event(at(6.0), b, GoalEvent::Accepted);
        assert_eq!(n.stuck(), None);
        n.on_event(at(7.0), b, GoalEvent::Finished(status::ABORTED));
        assert!(n.stuck().is_some_and(|s| s.contains("aborted")));
        let c = sent(&n.step(at(7.1), Some((5.0, 5.0)), false, Pose::default()).0).expect("a new target goes at once");
        assert_eq!(n.stuck(), None);
        n.on_event(at(7.2), c, GoalEvent::Failed("x".repeat(10_000)));
        assert!(n.stuck().is_some_and(|s| s.len() <= MAX_REASON));
        n.on_event(at(7.3), [9; 16], GoalEvent::Finished(status::SUCCEEDED));
        assert!(!n.step(at(7.4), Some((5.0, 5.0)), false, Pose::default()).1, "a stranger's goal id changes nothing");
    }

    #[test]
    fn repeated_recoveries_are_reported_until_the_goal_is_reached() {
        let (mut n, a) = sending([6; 16]);
        n.on_event(at(0.1), a, GoalEvent::Accepted);
        n.on_event(at(1.0), a, GoalEvent::Feedback { recoveries: RECOVERIES_REPORTED - 1, distance_remaining: 0.8 });
        assert_eq!(n.stuck(), None);
        n.on_event(at(2.0), a, GoalEvent::Feedback { recoveries: RECOVERIES_REPORTED, distance_remaining: 0.8 });
        assert!(n.stuck().is_some_and(|s| s.contains("recovering") && s.contains("0.8 m left")), "{:?}", n.stuck());
        assert_eq!(n.step(at(2.1), Some((1.0, 0.0)), false, Pose::default()), (vec![], false), "the goal is not given up");
        n.on_event(at(3.0), [0; 16], GoalEvent::Feedback { recoveries: 9, distance_remaining: 1.0 });
        n.on_event(at(4.0), a, GoalEvent::Finished(status::SUCCEEDED));
        assert_eq!(n.stuck(), None);
    }

    #[test]
    fn a_server_that_leaves_takes_its_goal() {
        let (mut n, a) = sending([4; 16]);
        n.set_server(false);
        assert_eq!(n.step(at(0.1), Some((1.0, 0.0)), false, Pose::default()).0, vec![]);
        assert!(n.stuck().is_some());
        n.set_server(true);
        let b = sent(&n.step(at(0.2), Some((1.0, 0.0)), false, Pose::default()).0).expect("sent to the new server");
        assert_ne!(a, b);
    }
}
