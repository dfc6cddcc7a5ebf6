//! Plan execution on a robot: walks the plan's steps, asks the body to move, and takes part in
//! team barriers (either mode of [`BarrierMode`]). No I/O: [`Executor::handle`] takes the time
//! and an [`Event`] and returns the [`Command`]s for the robot.

use std::collections::BTreeMap;

use mrmm_proto::{BarrierMode, PlanAssignment, Progress, RobotId, Step, SyncArrival, SyncRelease, Time};

use crate::body::Onward;
use crate::robot::barrier::Barrier;

mod ahead;
mod handover;

/// Wall seconds between two re-publications of an arrival while waiting at a barrier, for
/// members that subscribed after the first one (a network matter: it does not speed up with
/// the simulated clock; see [`Executor::with_time_scale`]).
pub const REPUBLISH_S: f64 = 0.5;
/// While a robot waits at one barrier, each re-publication doubles the gap before the next, up
/// to this many times [`REPUBLISH_S`]: a long wait (a teammate still driving to its slot, a
/// network slow to link) costs a few messages, not two a second per robot. A teammate's token
/// appearing (it has just joined and may have missed our arrival) brings the gap back to one.
pub const REPUBLISH_BACKOFF: f64 = 4.0;
/// Instantaneous steps taken at most per tick (a loop of such steps cannot spin for ever).
const MAX_STEPS_PER_TICK: usize = 64;

/// Something that happened to the plan's robot.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// Time passed; `body_idle`: the body has no goal (it arrived, or holds).
    Tick { body_idle: bool },
    /// A teammate's barrier arrival was heard.
    Heard(SyncArrival),
    /// A leader's release was heard ([`BarrierMode::Leader`]).
    Released(SyncRelease),
    /// An arrival at a barrier of a wider team (a scope of [`PlanAssignment::scopes`], by its
    /// team path) was heard.
    HeardIn(String, SyncArrival),
    /// A teammate's membership token appeared.
    MemberAlive(RobotId),
    /// A teammate's membership token disappeared: it no longer holds anyone up.
    MemberGone(RobotId),
}

/// What the robot must do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Drive to (x, y), speed capped at `speed` (None: the robot's maximum); `then`: where the
    /// plan drives on to from there without stopping (the body may round the corner).
    Navigate { x: f64, y: f64, then: Option<Onward>, speed: Option<f64> },
    /// Stop.
    Hold,
    /// Stop and turn on the spot to face (x, y), the plan's next point: sent when the robot
    /// starts waiting at a barrier.
    Face { x: f64, y: f64 },
    /// Publish this barrier arrival.
    Publish(SyncArrival),
    /// Publish this arrival at a barrier of the wider team of this path (always a mesh barrier).
    PublishIn(String, SyncArrival),
    /// Announce this release to the team (this robot leads its barriers).
    Release(SyncRelease),
    /// This robot now leads the team's barriers (`true`: hear the team's arrivals) or no longer.
    Lead(bool),
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
    /// At the barrier it waits at, the robot still turns to face its next point: its arrival
    /// is published once it faces it.
    turning: bool,
    /// When the robot arrived at the barrier it waits at (simulated seconds).
    waiting_since: Time,
    /// Simulated seconds spent waiting at barriers that released since the first (the
    /// formation's) under this plan.
    sync_wait: f64,
    /// Simulated seconds the plan waited for traffic.
    traffic_wait: f64,
    last_publish: Time,
    /// [`REPUBLISH_S`] in simulated seconds.
    republish: f64,
    /// The gap before the next re-publication while waiting ([`REPUBLISH_BACKOFF`]).
    gap: f64,
    /// A teammate seems to wait for an arrival of ours it missed: publish our furthest again.
    echo_due: bool,
    last_echo: Time,
    hold_until: Option<Time>,
    navigating: bool,
    done: bool,
    /// What the runtime was last told by [`Command::Lead`].
    leading: bool,
    /// The furthest release this robot announced as leader, and when it last announced one.
    announced: Option<(u32, u32)>,
    last_release: Time,
    /// A member asked for a barrier already released: announce it again.
    release_echo_due: bool,
    /// The leader known to have our furthest arrival (it released up to it).
    acked_by: Option<RobotId>,
    /// Barriers of wider teams (a parent team, the whole mission), by team path.
    wide: BTreeMap<String, Wide>,
}

/// A barrier of a team wider than the robot's own: every member of that scope hears every
/// arrival (the mesh barrier, whatever the team's own mode).
#[derive(Debug, Clone)]
struct Wide {
    barrier: Barrier,
    waiting: Option<(u32, u32)>,
    /// As [`Executor::turning`], for this barrier.
    turning: bool,
    last_publish: Time,
    /// As [`Executor::gap`], for this barrier.
    gap: f64,
    echo_due: bool,
    last_echo: Time,
}

impl Executor {
    pub fn new(assignment: PlanAssignment) -> Self {
        let barrier = Barrier::new(assignment.plan.robot.as_str(), assignment.epoch, &assignment.members).with_mode(assignment.barrier);
        let wide = assignment
            .scopes
            .iter()
            .filter(|s| s.team != assignment.team)
            .map(|s| {
                let barrier = Barrier::new(assignment.plan.robot.as_str(), assignment.epoch, &s.members);
                (
                    s.team.clone(),
                    Wide { barrier, waiting: None, turning: false, last_publish: Time::ZERO, gap: REPUBLISH_S, echo_due: false, last_echo: Time::LONG_AGO },
                )
            })
            .collect();
        Executor {
            wide,
            assignment,
            barrier,
            pc: 0,
            round: 0,
            loops: BTreeMap::new(),
            syncs_passed: 0,
            sync_msgs: 0,
            waiting: None,
            turning: false,
            waiting_since: Time::ZERO,
            sync_wait: 0.0,
            traffic_wait: 0.0,
            last_publish: Time::ZERO,
            republish: REPUBLISH_S,
            gap: REPUBLISH_S,
            echo_due: false,
            last_echo: Time::LONG_AGO,
            hold_until: None,
            navigating: false,
            done: false,
            leading: false,
            announced: None,
            last_release: Time::LONG_AGO,
            release_echo_due: false,
            acked_by: None,
        }
    }

    /// For a robot whose clock runs `scale` times faster than the wall: re-publications keep
    /// their wall-clock period (at a time scale of 10 they would otherwise go out at 20 Hz).
    pub fn with_time_scale(mut self, scale: f64) -> Self {
        if scale.is_finite() && scale > 0.0 {
            self.republish = REPUBLISH_S * scale;
            self.gap = self.republish;
            self.wide.values_mut().for_each(|w| w.gap = self.republish);
        }
        self
    }

    /// The plan it runs, as central gave it.
    pub fn assignment(&self) -> &PlanAssignment {
        &self.assignment
    }

    pub fn mission(&self) -> &str {
        self.assignment.mission.as_str()
    }

    pub fn epoch(&self) -> u64 {
        self.assignment.epoch
    }

    /// The team's barriers as this robot sees them.
    pub fn barrier(&self) -> &Barrier {
        &self.barrier
    }

    /// The barriers of the wider team of path `team`, if the plan has any.
    pub fn wide_barrier(&self, team: &str) -> Option<&Barrier> {
        self.wide.get(team).map(|w| &w.barrier)
    }

    /// The barrier (round, point) this robot waits at in the team of path `team` (its own or a
    /// wider one), if it waits there.
    pub fn waiting_in(&self, team: &str) -> Option<(u32, u32)> {
        if team == self.assignment.team {
            return self.waiting.map(|(point, round)| (round, point));
        }
        self.wide.get(team).and_then(|w| w.waiting)
    }

    /// The plan waited `dt` simulated seconds for traffic.
    pub fn waited_for_traffic(&mut self, dt: f64) {
        if dt.is_finite() && dt > 0.0 {
            self.traffic_wait += dt;
        }
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
            waiting: self.waiting.or_else(|| self.wide.values().find_map(|w| w.waiting).map(|(round, point)| (point, round))),
            sync_wait_s: self.sync_wait,
            traffic_wait_s: self.traffic_wait,
            done: self.done,
        }
    }

    /// Handles one event at `now` (the robot's simulated seconds).
    pub fn handle(&mut self, now: Time, ev: Event) -> Vec<Command> {
        match ev {
            Event::Tick { body_idle } => self.tick(now, body_idle),
            Event::Heard(a) => {
                self.heard(&a);
                self.lead(now)
            }
            Event::Released(r) => {
                if self.barrier.release_heard(&r) && r.leader == self.barrier.leader() && self.barrier.mine().is_none_or(|m| m <= (r.round, r.point)) {
                    self.acked_by = Some(r.leader);
                }
                vec![]
            }
            Event::HeardIn(team, a) => {
                if let Some(w) = self.wide.get_mut(&team) {
                    if w.barrier.arrival(&a) && w.barrier.at_or_behind_us(&a) && w.waiting != Some((a.round, a.point)) {
                        w.echo_due = true;
                    }
                }
                vec![]
            }
            Event::MemberAlive(id) => {
                self.barrier.member_alive(id.as_str());
                self.gap = self.republish;
                for w in self.wide.values_mut() {
                    w.barrier.member_alive(id.as_str());
                    w.gap = self.republish;
                }
                self.lead(now)
            }
            Event::MemberGone(id) => {
                self.barrier.member_gone(id.as_str());
                self.wide.values_mut().for_each(|w| w.barrier.member_gone(id.as_str()));
                self.lead(now)
            }
        }
    }

    /// The leader's part ([`BarrierMode::Leader`]): tells the runtime when this robot starts or
    /// stops leading, and announces every barrier it knows released — once when it is, and again
    /// (at most every `REPUBLISH_S`) when a member asks for one already released.
    fn lead(&mut self, now: Time) -> Vec<Command> {
        let mut out = Vec::new();
        if self.barrier.mode() != BarrierMode::Leader {
            return out;
        }
        let leading = self.barrier.leading();
        if leading != self.leading {
            self.leading = leading;
            out.push(Command::Lead(leading));
        }
        if !leading {
            return out;
        }
        let Some(r) = self.barrier.releasable() else { return out };
        let news = self.announced.is_none_or(|a| r > a);
        if news || (self.release_echo_due && now - self.last_release >= self.republish) {
            self.announced = Some(r);
            self.last_release = now;
            self.release_echo_due = false;
            self.sync_msgs += 1;
            out.push(Command::Release(SyncRelease { leader: self.assignment.plan.robot.clone(), epoch: self.assignment.epoch, point: r.1, round: r.0 }));
        }
        out
    }

    /// A teammate's arrival. One at or before our own furthest arrival, where we are not waiting
    /// ourselves, means its sender has not heard of ours (it re-publishes only while it waits):
    /// we publish ours again (at most every `REPUBLISH_S`, at the next tick). In the normal case
    /// this never happens, so the team still sends one message per member per barrier — and a
    /// member that missed the last arrivals of a finite plan is not left waiting for ever.
    fn heard(&mut self, a: &SyncArrival) {
        let counted = self.barrier.arrival(a);
        match self.barrier.mode() {
            BarrierMode::Mesh => {
                if counted && self.barrier.at_or_behind_us(a) && self.waiting != Some((a.point, a.round)) {
                    self.echo_due = true;
                }
            }
            // Its sender waits for a release it missed.
            BarrierMode::Leader => {
                if counted && a.robot != self.assignment.plan.robot && self.barrier.releasable().is_some_and(|r| r >= (a.round, a.point)) {
                    self.release_echo_due = true;
                }
            }
        }
    }

    /// Publishes our arrival `at` (round, point) unless we lead (the leader's own arrival is
    /// counted where it is heard: here).
    fn publish(&mut self, now: Time, at: (u32, u32), out: &mut Vec<Command>) {
        self.last_publish = now;
        if self.barrier.leading() {
            return;
        }
        self.sync_msgs += 1;
        out.push(Command::Publish(SyncArrival { robot: self.assignment.plan.robot.clone(), epoch: self.assignment.epoch, point: at.1, round: at.0 }));
    }

    /// This robot is at barrier `point` of the current round of wider team `team`: publishes its
    /// arrival (again every `REPUBLISH_S` while it waits); whether the barrier released. A plan
    /// whose scope has no members listed (refused when the plan comes in) passes at once.
    fn wide_sync(&mut self, now: Time, team: &str, point: u32, body_idle: bool, out: &mut Vec<Command>) -> bool {
        let (me, epoch, round, republish) = (self.assignment.plan.robot.clone(), self.assignment.epoch, self.round, self.republish);
        let next = ahead::next_point(&self.assignment.plan.steps, self.pc);
        let first = self.syncs_passed == 0;
        let Some(w) = self.wide.get_mut(team) else { return true };
        let at = (round, point);
        let arrival = SyncArrival { robot: me, epoch, point, round };
        let fresh = w.waiting != Some(at);
        // As at the team's own barriers: at the first, the arrival waits for the turn.
        let announce = if fresh {
            w.waiting = Some(at);
            self.waiting_since = now;
            w.turning = first && next.is_some();
            if w.turning {
                out.extend(next.map(|(x, y)| Command::Face { x, y }));
                return false;
            }
            true
        } else if w.turning {
            if !body_idle {
                return false;
            }
            w.turning = false;
            true
        } else {
            false
        };
        if announce {
            w.gap = republish;
            w.barrier.arrival(&arrival);
        }
        if !w.barrier.released(point, round) {
            if announce || now - w.last_publish >= w.gap {
                if !announce {
                    w.gap = (w.gap * 2.0).min(republish * REPUBLISH_BACKOFF);
                }
                w.last_publish = now;
                self.sync_msgs += 1;
                out.push(Command::PublishIn(team.to_string(), arrival));
            }
            if fresh {
                out.extend(next.map(|(x, y)| Command::Face { x, y }));
            }
            return false;
        }
        w.barrier.passed(at);
        w.waiting = None;
        if self.syncs_passed > 0 {
            self.sync_wait += (now - self.waiting_since).max(0.0);
        }
        self.syncs_passed += 1;
        tracing::debug!(target: "mrmm_peer::barrier", mission = %self.assignment.mission, team, epoch, point, round, "released");
        true
    }

    /// Advances the plan. `now`: simulated seconds; `body_idle`: the body has no goal (arrived).
    fn tick(&mut self, now: Time, body_idle: bool) -> Vec<Command> {
        let mut out = self.lead(now);
        self.resend(now, &mut out);
        for _ in 0..MAX_STEPS_PER_TICK {
            if self.done {
                break;
            }
            let Some(step) = self.assignment.plan.steps.get(self.pc).cloned() else {
                self.done = true;
                out.push(Command::Hold);
                break;
            };
            if !self.step(now, body_idle, step, &mut out) {
                break;
            }
        }
        out
    }

    /// What is said again at this tick: a member whose leader changed re-sends its furthest
    /// arrival until the new leader has released up to it (the new leader may need it for a
    /// barrier others still wait at); echoes of our furthest arrival to teammates behind us.
    fn resend(&mut self, now: Time, out: &mut Vec<Command>) {
        if self.barrier.mode() == BarrierMode::Leader
            && !self.barrier.leading()
            && self.waiting.is_none()
            && self.acked_by.as_ref().map(|x| x.as_str()) != Some(self.barrier.leader())
            && now - self.last_publish >= self.republish
        {
            if let Some(at) = self.barrier.mine() {
                self.publish(now, at, out);
            }
        }
        let me = &self.assignment.plan.robot;
        if self.echo_due && now - self.last_echo >= self.republish {
            if let Some((round, point)) = self.barrier.mine() {
                self.echo_due = false;
                self.last_echo = now;
                self.sync_msgs += 1;
                out.push(Command::Publish(SyncArrival { robot: me.clone(), epoch: self.assignment.epoch, point, round }));
            }
        }
        for (team, w) in &mut self.wide {
            if w.echo_due && now - w.last_echo >= self.republish {
                if let Some((round, point)) = w.barrier.mine() {
                    w.echo_due = false;
                    w.last_echo = now;
                    self.sync_msgs += 1;
                    out.push(Command::PublishIn(team.clone(), SyncArrival { robot: me.clone(), epoch: self.assignment.epoch, point, round }));
                }
            }
        }
    }

    /// Takes the plan's current step; false while it is not done (the tick ends there).
    fn step(&mut self, now: Time, body_idle: bool, step: Step, out: &mut Vec<Command>) -> bool {
        match step {
            Step::Stream => {}
            Step::Navigate { x, y, speed } => {
                if !self.navigating {
                    self.navigating = true;
                    out.push(Command::Navigate { x, y, then: ahead::onward(&self.assignment.plan.steps, self.pc, &self.loops), speed });
                    return false;
                }
                if !body_idle {
                    return false;
                }
                self.navigating = false;
            }
            Step::Sync { point, scope: Some(scope) } if self.assignment.scope_path(Some(&scope)) != self.assignment.team => {
                let team = self.assignment.scope_path(Some(&scope));
                if !self.wide_sync(now, &team, point, body_idle, out) {
                    return false;
                }
            }
            Step::Sync { point, .. } => {
                if !self.own_sync(now, point, body_idle, out) {
                    return false;
                }
            }
            Step::Hold { seconds } => {
                let until = *self.hold_until.get_or_insert_with(|| {
                    out.push(Command::Hold);
                    seconds.map_or(Time::NEVER, |s| now + s)
                });
                if now < until {
                    return false;
                }
                self.hold_until = None;
            }
            Step::Loop { to, rounds } => {
                let count = self.loops.entry(self.pc).or_insert(0);
                *count = count.saturating_add(1);
                self.round = self.round.saturating_add(1);
                if !(rounds.is_some_and(|r| *count >= r) || to >= self.pc) {
                    self.pc = to;
                    return true;
                }
            }
        }
        self.pc += 1;
        true
    }

    /// Our arrival at barrier `point` of the current round: counted, published, led.
    fn announce(&mut self, now: Time, point: u32, out: &mut Vec<Command>) {
        let arrival = SyncArrival { robot: self.assignment.plan.robot.clone(), epoch: self.assignment.epoch, point, round: self.round };
        self.barrier.arrival(&arrival);
        self.gap = self.republish;
        self.publish(now, (self.round, point), out);
        out.extend(self.lead(now));
    }

    /// This robot is at barrier `point` of its own team's current round: publishes its arrival
    /// (again while it waits, backing off) and turns to face the plan's next point; whether the
    /// barrier released. At the plan's first barrier the arrival waits for the turn (`body_idle`
    /// again): robots come to their slots from anywhere, and one that came last, up to a U-turn
    /// from its way, and announced itself before turning would leave after the others and stay
    /// behind its slot's time for the whole first leg. Later barriers are reached driving the
    /// plan's way: the turn there is made while waiting, as the plan's timing counts it.
    fn own_sync(&mut self, now: Time, point: u32, body_idle: bool, out: &mut Vec<Command>) -> bool {
        let at = (point, self.round);
        if self.waiting != Some(at) {
            self.waiting = Some(at);
            self.waiting_since = now;
            let next = ahead::next_point(&self.assignment.plan.steps, self.pc);
            self.turning = next.is_some() && self.syncs_passed == 0;
            if self.turning {
                out.extend(next.map(|(x, y)| Command::Face { x, y }));
                return false;
            }
            self.announce(now, point, out);
            out.extend(next.map(|(x, y)| Command::Face { x, y }));
        } else if self.turning {
            if !body_idle {
                return false;
            }
            self.turning = false;
            self.announce(now, point, out);
        }
        if !self.barrier.released(point, self.round) {
            if now - self.last_publish >= self.gap {
                self.gap = (self.gap * 2.0).min(self.republish * REPUBLISH_BACKOFF);
                self.publish(now, (self.round, point), out);
            }
            return false;
        }
        self.barrier.passed((self.round, point));
        self.waiting = None;
        // The first barrier gathers the team at its slots (the formation): its wait is not the
        // cost of synchronising the rounds.
        if self.syncs_passed > 0 {
            self.sync_wait += (now - self.waiting_since).max(0.0);
        }
        self.syncs_passed += 1;
        // The release instant, for latency measurements (`benches/scale.rs`).
        tracing::debug!(target: "mrmm_peer::barrier", mission = %self.assignment.mission, epoch = self.assignment.epoch, point, round = self.round, "released");
        true
    }
}

#[cfg(test)]
mod tests;
