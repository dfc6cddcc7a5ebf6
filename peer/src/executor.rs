//! Plan execution on a robot: walks the plan's steps, asks the body to move, and takes part in
//! team barriers. No I/O: [`Executor::handle`] takes the time and an [`Event`] and returns the
//! [`Command`]s for the robot.

use std::collections::BTreeMap;

use mrmm_proto::{PlanAssignment, Progress, Step, SyncArrival};

use crate::barrier::Barrier;

/// Wall seconds between two re-publications of an arrival while waiting at a barrier, for
/// members that subscribed after the first one (a network matter: it does not speed up with
/// the simulated clock; see [`Executor::with_time_scale`]).
pub const REPUBLISH_S: f64 = 0.5;
/// Instantaneous steps taken at most per tick (a loop of such steps cannot spin for ever).
const MAX_STEPS_PER_TICK: usize = 64;

/// Something that happened to the plan's robot.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Time passed; `body_idle`: the body has no goal (it arrived, or holds).
    Tick { body_idle: bool },
    /// A teammate's barrier arrival was heard.
    Heard(SyncArrival),
    /// A teammate's membership token appeared.
    MemberAlive(String),
    /// A teammate's membership token disappeared: it no longer holds anyone up.
    MemberGone(String),
}

/// What the robot must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Drive to (x, y), speed capped at `speed` (None: the robot's maximum).
    Navigate { x: f64, y: f64, speed: Option<f64> },
    /// Stop.
    Hold,
    /// Publish this barrier arrival.
    Publish(SyncArrival),
}

/// The execution state of one plan.
#[derive(Debug, Clone)]
pub struct Executor {
    pub assignment: PlanAssignment,
    barrier: Barrier,
    pc: usize,
    round: u32,
    loops: BTreeMap<usize, u32>,
    syncs_passed: u32,
    sync_msgs: u32,
    waiting: Option<(u32, u32)>,
    /// When the robot arrived at the barrier it waits at (simulated seconds).
    waiting_since: f64,
    /// Simulated seconds spent waiting at barriers that released since the first (the
    /// formation's) under this plan.
    sync_wait: f64,
    last_publish: f64,
    /// [`REPUBLISH_S`] in simulated seconds.
    republish: f64,
    /// A teammate seems to wait for an arrival of ours it missed: publish our furthest again.
    echo_due: bool,
    last_echo: f64,
    hold_until: Option<f64>,
    navigating: bool,
    done: bool,
}

impl Executor {
    pub fn new(assignment: PlanAssignment) -> Self {
        let barrier = Barrier::new(&assignment.plan.robot, assignment.epoch, &assignment.members);
        Executor {
            assignment,
            barrier,
            pc: 0,
            round: 0,
            loops: BTreeMap::new(),
            syncs_passed: 0,
            sync_msgs: 0,
            waiting: None,
            waiting_since: 0.0,
            sync_wait: 0.0,
            last_publish: 0.0,
            republish: REPUBLISH_S,
            echo_due: false,
            last_echo: f64::NEG_INFINITY,
            hold_until: None,
            navigating: false,
            done: false,
        }
    }

    /// For a robot whose clock runs `scale` times faster than the wall: re-publications keep
    /// their wall-clock period (at a time scale of 10 they would otherwise go out at 20 Hz).
    pub fn with_time_scale(mut self, scale: f64) -> Self {
        if scale.is_finite() && scale > 0.0 {
            self.republish = REPUBLISH_S * scale;
        }
        self
    }

    pub fn mission(&self) -> &str {
        &self.assignment.mission
    }

    pub fn epoch(&self) -> u64 {
        self.assignment.epoch
    }

    /// The team's barriers as this robot sees them.
    pub fn barrier(&self) -> &Barrier {
        &self.barrier
    }

    /// Progress for telemetry.
    pub fn progress(&self) -> Progress {
        Progress {
            mission: self.assignment.mission.clone(),
            epoch: self.assignment.epoch,
            step: self.pc as u32,
            round: self.round,
            syncs_passed: self.syncs_passed,
            sync_msgs: self.sync_msgs,
            waiting: self.waiting,
            sync_wait_s: self.sync_wait,
            done: self.done,
        }
    }

    /// Handles one event at `now` (the robot's simulated seconds).
    pub fn handle(&mut self, now: f64, ev: Event) -> Vec<Command> {
        match ev {
            Event::Tick { body_idle } => self.tick(now, body_idle),
            Event::Heard(a) => {
                self.heard(&a);
                vec![]
            }
            Event::MemberAlive(id) => {
                self.barrier.member_alive(&id);
                vec![]
            }
            Event::MemberGone(id) => {
                self.barrier.member_gone(&id);
                vec![]
            }
        }
    }

    /// A teammate's arrival. One at or before our own furthest arrival, where we are not waiting
    /// ourselves, means its sender has not heard of ours (it re-publishes only while it waits):
    /// we publish ours again (at most every `REPUBLISH_S`, at the next tick). In the normal case
    /// this never happens, so the team still sends one message per member per barrier — and a
    /// member that missed the last arrivals of a finite plan is not left waiting for ever.
    fn heard(&mut self, a: &SyncArrival) {
        let counted = self.barrier.arrival(a);
        if counted && self.barrier.at_or_behind_us(a) && self.waiting != Some((a.point, a.round)) {
            self.echo_due = true;
        }
    }

    /// Advances the plan. `now`: simulated seconds; `body_idle`: the body has no goal (arrived).
    fn tick(&mut self, now: f64, body_idle: bool) -> Vec<Command> {
        let mut out = Vec::new();
        let me = self.assignment.plan.robot.clone();
        if self.echo_due && now - self.last_echo >= self.republish {
            if let Some((round, point)) = self.barrier.mine() {
                self.echo_due = false;
                self.last_echo = now;
                self.sync_msgs += 1;
                out.push(Command::Publish(SyncArrival { robot: me.clone(), epoch: self.assignment.epoch, point, round }));
            }
        }
        for _ in 0..MAX_STEPS_PER_TICK {
            if self.done {
                break;
            }
            let Some(step) = self.assignment.plan.steps.get(self.pc).cloned() else {
                self.done = true;
                out.push(Command::Hold);
                break;
            };
            match step {
                Step::Stream => self.pc += 1,
                Step::Navigate { x, y, speed } => {
                    if !self.navigating {
                        self.navigating = true;
                        out.push(Command::Navigate { x, y, speed });
                        break;
                    }
                    if !body_idle {
                        break;
                    }
                    self.navigating = false;
                    self.pc += 1;
                }
                Step::Sync { point } => {
                    let at = (point, self.round);
                    let arrival = SyncArrival { robot: me.clone(), epoch: self.assignment.epoch, point, round: self.round };
                    if self.waiting != Some(at) {
                        self.waiting = Some(at);
                        self.waiting_since = now;
                        self.barrier.arrival(&arrival);
                        self.sync_msgs += 1;
                        self.last_publish = now;
                        out.push(Command::Publish(arrival));
                    }
                    if !self.barrier.released(point, self.round) {
                        if now - self.last_publish >= self.republish {
                            self.sync_msgs += 1;
                            self.last_publish = now;
                            out.push(Command::Publish(SyncArrival { robot: me.clone(), epoch: self.assignment.epoch, point, round: self.round }));
                        }
                        break;
                    }
                    self.waiting = None;
                    // The first barrier gathers the team at its slots (the formation): its wait
                    // is not the cost of synchronising the rounds.
                    if self.syncs_passed > 0 {
                        self.sync_wait += (now - self.waiting_since).max(0.0);
                    }
                    self.syncs_passed += 1;
                    // The release instant, for latency measurements (`benches/scale.rs`).
                    tracing::debug!(target: "mrmm_peer::barrier", mission = %self.assignment.mission, epoch = self.assignment.epoch, point, round = self.round, "released");
                    self.pc += 1;
                }
                Step::Hold { seconds } => {
                    let until = *self.hold_until.get_or_insert_with(|| {
                        out.push(Command::Hold);
                        seconds.map_or(f64::INFINITY, |s| now + s)
                    });
                    if now < until {
                        break;
                    }
                    self.hold_until = None;
                    self.pc += 1;
                }
                Step::Loop { to, rounds } => {
                    let count = self.loops.entry(self.pc).or_insert(0);
                    *count = count.saturating_add(1);
                    self.round = self.round.saturating_add(1);
                    if rounds.is_some_and(|r| *count >= r) || to >= self.pc {
                        self.pc += 1;
                    } else {
                        self.pc = to;
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::RobotPlan;

    fn tick(e: &mut Executor, now: f64, body_idle: bool) -> Vec<Command> {
        e.handle(now, Event::Tick { body_idle })
    }

    fn exec(steps: Vec<Step>, members: &[&str]) -> Executor {
        Executor::new(PlanAssignment {
            mission: "m".into(),
            epoch: 2,
            team: "m".into(),
            subteam: "m/ground".into(),
            members: members.iter().map(|s| s.to_string()).collect(),
            plan: RobotPlan { robot: "a".into(), robot_type: "ground".into(), slot: 0, steps },
            managers: vec![],
        })
    }

    fn nav(x: f64) -> Step {
        Step::Navigate { x, y: 0.0, speed: Some(1.0) }
    }

    #[test]
    fn navigates_step_by_step_then_holds_at_the_end() {
        let mut e = exec(vec![Step::Stream, nav(1.0), nav(2.0)], &["a"]);
        assert_eq!(tick(&mut e, 0.0, true), vec![Command::Navigate { x: 1.0, y: 0.0, speed: Some(1.0) }]);
        assert!(tick(&mut e, 0.1, false).is_empty(), "still driving");
        assert_eq!(tick(&mut e, 0.2, true), vec![Command::Navigate { x: 2.0, y: 0.0, speed: Some(1.0) }]);
        assert_eq!(tick(&mut e, 0.3, true), vec![Command::Hold]);
        assert!(e.progress().done);
        assert!(tick(&mut e, 0.4, true).is_empty());
    }

    #[test]
    fn barrier_waits_republishes_and_releases() {
        let mut e = exec(vec![Step::Sync { point: 0 }, nav(1.0)], &["a", "b"]);
        let acts = tick(&mut e, 0.0, true);
        assert_eq!(acts, vec![Command::Publish(SyncArrival { robot: "a".into(), epoch: 2, point: 0, round: 0 })]);
        assert_eq!(e.progress().waiting, Some((0, 0)));
        assert!(tick(&mut e, 0.1, true).is_empty());
        assert_eq!(tick(&mut e, 0.6, true).len(), 1, "re-published while waiting");
        e.handle(0.65, Event::Heard(SyncArrival { robot: "b".into(), epoch: 2, point: 0, round: 0 }));
        assert_eq!(tick(&mut e, 0.7, true), vec![Command::Navigate { x: 1.0, y: 0.0, speed: Some(1.0) }]);
        let p = e.progress();
        assert_eq!((p.syncs_passed, p.sync_msgs, p.waiting), (1, 2, None));
        assert_eq!(p.sync_wait_s, 0.0, "the first barrier is the formation's");
    }

    #[test]
    fn barrier_wait_is_counted_after_the_formation() {
        let mut e = exec(vec![Step::Sync { point: 0 }, Step::Sync { point: 1 }], &["a", "b"]);
        let heard = |e: &mut Executor, t: f64, point: u32| e.handle(t, Event::Heard(SyncArrival { robot: "b".into(), epoch: 2, point, round: 0 }));
        tick(&mut e, 0.0, true);
        heard(&mut e, 2.0, 0);
        tick(&mut e, 2.0, true);
        tick(&mut e, 3.0, true);
        heard(&mut e, 3.5, 1);
        tick(&mut e, 3.7, true);
        let p = e.progress();
        assert_eq!(p.syncs_passed, 2);
        assert!((p.sync_wait_s - 1.7).abs() < 1e-9, "waited at the second barrier from 2.0 to 3.7: {}", p.sync_wait_s);
    }

    #[test]
    fn republication_keeps_its_wall_clock_period_on_a_fast_clock() {
        let mut e = exec(vec![Step::Sync { point: 0 }], &["a", "b"]).with_time_scale(10.0);
        assert_eq!(tick(&mut e, 0.0, true).len(), 1, "the arrival");
        assert!(tick(&mut e, 1.0, true).is_empty(), "0.1 wall seconds later: not yet");
        assert_eq!(tick(&mut e, 5.0, true).len(), 1, "0.5 wall seconds later: again");
    }

    #[test]
    fn a_teammate_that_missed_our_last_arrival_gets_it_again() {
        let arrival = |robot: &str| SyncArrival { robot: robot.into(), epoch: 2, point: 0, round: 0 };
        let mut e = exec(vec![Step::Sync { point: 0 }], &["a", "b"]);
        tick(&mut e, 0.0, true);
        // b's arrival while we wait there ourselves: the normal case, no echo.
        e.handle(0.0, Event::Heard(arrival("b")));
        assert_eq!(tick(&mut e, 0.1, true), vec![Command::Hold], "released: the plan is over");
        // b publishes that arrival again: it is still waiting, it missed ours. We say it again.
        e.handle(0.0, Event::Heard(arrival("b")));
        assert_eq!(tick(&mut e, 0.2, true), vec![Command::Publish(arrival("a"))]);
        e.handle(0.0, Event::Heard(arrival("b")));
        assert!(tick(&mut e, 0.3, true).is_empty(), "at most every REPUBLISH_S");
        assert_eq!(tick(&mut e, 0.8, true), vec![Command::Publish(arrival("a"))]);
    }

    #[test]
    fn a_lost_teammate_does_not_block() {
        let mut e = exec(vec![Step::Sync { point: 0 }, Step::Hold { seconds: None }], &["a", "b"]);
        tick(&mut e, 0.0, true);
        e.handle(0.05, Event::MemberGone("b".into()));
        assert_eq!(tick(&mut e, 0.1, true), vec![Command::Hold]);
    }

    #[test]
    fn loops_count_rounds_and_barriers_are_per_round() {
        let steps = vec![Step::Sync { point: 0 }, nav(1.0), Step::Sync { point: 1 }, Step::Loop { to: 1, rounds: Some(2) }];
        let mut e = exec(steps, &["a"]);
        let mut published = Vec::new();
        for i in 0..20 {
            for a in tick(&mut e, i as f64, true) {
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
        assert_eq!(tick(&mut e, 0.0, true), vec![Command::Hold]);
        assert!(tick(&mut e, 0.5, true).is_empty());
        // Past the hold: an endless loop of instantaneous steps is bounded per tick.
        assert!(tick(&mut e, 1.5, true).is_empty());
        assert!(e.progress().round > 0);
    }
}
