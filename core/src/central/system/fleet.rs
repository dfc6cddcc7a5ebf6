//! The registry: the fleet as the system manager knows it — every robot's record (liveliness,
//! what it said of itself, its latest telemetry) and the mission hosts alive, bounded whatever the
//! network says. A machine of its own: [`Fleet::handle`] takes what was heard of robots and hosts
//! ([`Heard`]) and returns what it decided ([`Fact`]: ask a robot who it is, a robot lost or back,
//! newer telemetry to act on); the missions' side of the system manager acts on the facts.

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{ErrorReply, Key, Member, NodeId, RobotId, RobotInfo, RobotSpec, Telemetry, Time};

use super::candidates::Candidates;
use super::{FETCH_PER_TICK, INFO_RETRY_S, MAX_FLEET};

/// One robot as the system manager knows it.
#[derive(Debug, Clone)]
pub(super) struct Record {
    pub(super) info: Option<RobotInfo>,
    pub(super) alive: bool,
    pub(super) last: Option<Telemetry>,
    /// When the last info request went out (seconds, driver clock).
    pub(super) info_asked: Option<Time>,
    /// Set when the robot (re)appears: its sequence numbers may restart from 1.
    pub(super) fresh: bool,
    /// When we last ordered it out of a plan it should not run.
    pub(super) leave_sent: Option<Time>,
    /// When it was last admitted again to its mission (it restarted and forgot).
    pub(super) admit_sent: Option<Time>,
    /// Seen coming (back) since a head last listed it as present: only such a robot is taken
    /// back when its head reports it lost (a head may see a loss before this manager does).
    pub(super) back: bool,
    /// When its liveliness last appeared.
    pub(super) alive_at: Time,
    /// When its liveliness last went away.
    pub(super) lost_at: Time,
}

impl Record {
    /// Alive and registered: it can be planned for.
    pub(super) fn ready(&self) -> bool {
        self.alive && self.info.is_some()
    }
}

/// What a robot's token appearing meant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Appeared {
    /// An id not registered: a candidate until it answers who it is (asked now, or later).
    Candidate { ask: bool },
    /// A robot that was lost.
    Back,
    /// Alive already (a repeated token).
    Again,
}

/// What the registry hears: the robot and host events of the system manager.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Heard {
    /// A robot's liveliness token appeared.
    Alive(RobotId),
    /// A robot's liveliness token disappeared.
    Gone(RobotId),
    /// A robot answered its info query.
    Info(RobotInfo),
    /// An info query failed.
    InfoFailed { id: RobotId, reason: String },
    /// A robot's telemetry.
    Telemetry(Box<Telemetry>),
    /// A mission host's token appeared.
    HostAlive(NodeId),
    /// A mission host's token disappeared.
    HostGone(NodeId),
    /// Time passed: info queries left unanswered are asked again.
    Tick,
}

/// What the registry decided, for the system manager to act on, in order.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Fact {
    /// Ask the robot who it is.
    Fetch(RobotId),
    /// A robot that was lost is alive again (asked who it is next).
    Back(RobotId),
    /// A robot alive until now lost its token; its record stays.
    Lost(RobotId),
    /// A robot said who it is (its record holds what it said, when its token was seen).
    Registered(RobotId),
    /// A robot's telemetry newer than what the registry holds: what it runs is for the
    /// missions to check; then it is kept as the robot's latest ([`Fleet::keep`]).
    Heard(Box<Telemetry>),
    /// A mission host's token went away.
    HostLost(NodeId),
}

/// Every robot and mission host the system manager knows.
#[derive(Debug, Clone, Default)]
pub(super) struct Fleet {
    robots: BTreeMap<RobotId, Record>,
    /// Mission hosts alive.
    hosts: BTreeSet<NodeId>,
    /// Ids heard of that have not registered yet (`candidates.rs`): not in `robots`.
    candidates: Candidates,
    /// New robots not registered because the registry is full.
    ignored: u64,
    /// Robots alive that have not answered their info query since their token appeared: asked
    /// again until they do (a robot back from a restart may have changed type or capabilities,
    /// and the answer to the first question may be lost, leaving the record it had before). What
    /// a tick looks through, not the whole fleet.
    unanswered: BTreeSet<RobotId>,
}

impl Fleet {
    /// Takes one thing heard of a robot or a host at `now`; returns what it decided.
    pub(super) fn handle(&mut self, now: Time, heard: Heard) -> Vec<Fact> {
        match heard {
            Heard::Alive(id) => match self.appeared(id.as_str(), now) {
                Appeared::Candidate { ask: false } => vec![],
                Appeared::Back => vec![Fact::Back(id.clone()), Fact::Fetch(id)],
                Appeared::Candidate { ask: true } | Appeared::Again => vec![Fact::Fetch(id)],
            },
            Heard::Gone(id) => match self.disappeared(id.as_str(), now) {
                true => vec![Fact::Lost(id)],
                false => vec![],
            },
            Heard::Info(info) => {
                let id = info.id.clone();
                match self.registered(info, now) {
                    true => vec![Fact::Registered(id)],
                    false => vec![],
                }
            }
            Heard::InfoFailed { id, reason } => {
                tracing::debug!(robot = %id, "info request failed: {reason}");
                vec![]
            }
            Heard::Telemetry(t) => self.telemetry(now, t),
            Heard::HostAlive(node) => {
                self.host_up(node);
                vec![]
            }
            Heard::HostGone(node) => {
                self.host_down(node.as_str());
                vec![Fact::HostLost(node)]
            }
            Heard::Tick => self.fetch_due(now).into_iter().map(Fact::Fetch).collect(),
        }
    }

    /// A robot's telemetry: only one newer than the last counts (a robot that came back counts
    /// again from its first); a robot whose info changed since it was asked (its capabilities
    /// did) is asked again, at most once per [`INFO_RETRY_S`].
    fn telemetry(&mut self, now: Time, t: Box<Telemetry>) -> Vec<Fact> {
        let Some(rec) = self.robots.get_mut(&t.id) else {
            // Not registered: its own sealed telemetry vouches for it, and it is asked first.
            return match self.candidates.vouched(t.id.as_str(), now) {
                true => vec![Fact::Fetch(t.id.clone())],
                false => vec![],
            };
        };
        let newer = rec.fresh || rec.last.as_ref().is_none_or(|old| t.seq > old.seq);
        if !newer {
            return vec![];
        }
        rec.fresh = false;
        let mut out = Vec::new();
        let stale = rec.info.as_ref().is_some_and(|i| i.rev != t.info_rev);
        if stale && rec.info_asked.is_none_or(|a| now - a >= INFO_RETRY_S) {
            rec.info_asked = Some(now);
            out.push(Fact::Fetch(t.id.clone()));
        }
        out.push(Fact::Heard(t));
        out
    }

    /// Keeps `t` as its robot's latest telemetry (after [`Fact::Heard`] was acted on).
    pub(super) fn keep(&mut self, t: Telemetry) {
        if let Some(rec) = self.robots.get_mut(&t.id) {
            rec.last = Some(t);
        }
    }

    /// A robot's token appeared at `now`: a registered robot is alive, and asked who it is again
    /// (a restarted robot may have changed type or endpoints); any other id is a candidate until
    /// it answers (`candidates.rs`): a flood of made-up tokens never enters the registry.
    fn appeared(&mut self, id: &str, now: Time) -> Appeared {
        let Some(rec) = self.robots.get_mut(id) else {
            return Appeared::Candidate { ask: self.candidates.appeared(id, now) };
        };
        let seen = if rec.alive { Appeared::Again } else { Appeared::Back };
        rec.back |= seen == Appeared::Back;
        rec.alive = true;
        rec.alive_at = now;
        rec.fresh = true;
        rec.info_asked = Some(now);
        self.unanswered.insert(RobotId::from(id));
        seen
    }

    /// A robot's token disappeared: whether it was alive until now. Its record (and its place
    /// in a mission, which the missions keep) stays; a candidate is forgotten.
    fn disappeared(&mut self, id: &str, now: Time) -> bool {
        self.unanswered.remove(id);
        self.candidates.gone(id);
        let Some(r) = self.robots.get_mut(id) else { return false };
        if r.alive {
            r.lost_at = now;
        }
        std::mem::replace(&mut r.alive, false)
    }

    /// Robots lost for `after` seconds or more that `keep` does not keep (those in a mission
    /// keep their place) leave the registry: a fleet that saw thousands of robots come and go
    /// holds the ones it has. Returns how many went.
    pub(super) fn forget_lost(&mut self, now: Time, after: f64, keep: impl Fn(&RobotId) -> bool) -> usize {
        let before = self.robots.len();
        self.robots.retain(|id, r| r.alive || now - r.lost_at < after || keep(id));
        let gone = before - self.robots.len();
        if gone > 0 {
            tracing::info!(robots = gone, after_s = after, "robots lost that long and in no mission forgotten");
        }
        gone
    }

    /// What a robot said of itself (its sealed answer to the info question): a candidate enters
    /// the registry (unless it holds [`MAX_FLEET`] robots already); false if neither a record
    /// nor a candidate of it is alive (then ignored).
    fn registered(&mut self, info: RobotInfo, now: Time) -> bool {
        if !self.robots.contains_key(&info.id) {
            let Some(since) = self.candidates.take(info.id.as_str()) else {
                tracing::debug!(robot = %info.id, "info from a robot with no liveliness: ignored");
                return false;
            };
            if self.robots.len() >= MAX_FLEET {
                self.ignored = self.ignored.saturating_add(1);
                if self.ignored.is_power_of_two() {
                    tracing::warn!(robot = %info.id, ignored = self.ignored, "fleet registry full ({MAX_FLEET} robots): new robots ignored");
                }
                return false;
            }
            let rec = Record {
                info: None,
                alive: true,
                last: None,
                info_asked: Some(now),
                fresh: true,
                leave_sent: None,
                admit_sent: None,
                back: true,
                alive_at: since,
                lost_at: since,
            };
            self.robots.insert(info.id.clone(), rec);
        }
        let Some(rec) = self.robots.get_mut(&info.id) else { return false };
        match &rec.info {
            None => tracing::info!(robot = %info.id, r#type = %info.robot_type, "robot registered"),
            Some(old) if old.capabilities != info.capabilities => {
                tracing::info!(robot = %info.id, was = ?old.capabilities, now = ?info.capabilities, "robot capabilities changed")
            }
            Some(_) => {}
        }
        self.unanswered.remove(&info.id);
        rec.info = Some(info);
        true
    }

    /// Robots alive that have not answered their info query since their token appeared, to be
    /// asked again, then candidates (vouched ones first): at most [`FETCH_PER_TICK`] (a flood of
    /// tokens costs a bounded number of queries).
    fn fetch_due(&mut self, now: Time) -> Vec<RobotId> {
        let mut due = self.known_due(now);
        let budget = FETCH_PER_TICK.saturating_sub(due.len());
        due.extend(self.candidates.due(now, budget));
        due
    }

    /// Registered robots back that have not answered since, due to be asked again.
    fn known_due(&mut self, now: Time) -> Vec<RobotId> {
        let mut due = Vec::new();
        for id in &self.unanswered {
            if due.len() == FETCH_PER_TICK {
                break;
            }
            let Some(r) = self.robots.get_mut(id) else { continue };
            if r.info_asked.is_none_or(|t| now - t >= INFO_RETRY_S) {
                r.info_asked = Some(now);
                due.push(id.clone());
            }
        }
        due
    }

    pub(super) fn get(&self, id: &str) -> Option<&Record> {
        self.robots.get(id)
    }

    pub(super) fn get_mut(&mut self, id: &str) -> Option<&mut Record> {
        self.robots.get_mut(id)
    }

    /// Every robot's record, by id.
    pub(super) fn iter(&self) -> impl Iterator<Item = (&RobotId, &Record)> {
        self.robots.iter()
    }

    /// Its token is up.
    pub(super) fn alive(&self, id: &str) -> bool {
        self.robots.get(id).is_some_and(|r| r.alive)
    }

    /// Alive and registered.
    pub(super) fn ready(&self, id: &str) -> bool {
        self.robots.get(id).is_some_and(Record::ready)
    }

    /// Registered (alive or not).
    pub(super) fn known(&self, id: &str) -> bool {
        self.robots.get(id).is_some_and(|r| r.info.is_some())
    }

    /// How many robots are alive and registered.
    pub(super) fn ready_count(&self) -> usize {
        self.robots.values().filter(|r| r.ready()).count()
    }

    /// Its latest telemetry.
    pub(super) fn last(&self, id: &str) -> Option<&Telemetry> {
        self.robots.get(id).and_then(|r| r.last.as_ref())
    }

    /// What it has (nothing if unknown).
    pub(super) fn capabilities_of(&self, id: &str) -> &[String] {
        self.robots.get(id).and_then(|r| r.info.as_ref()).map(|i| i.capabilities.as_slice()).unwrap_or(&[])
    }

    /// The robot's info if it is registered and alive; else why not, in words.
    pub(super) fn live_robot(&self, id: &str) -> Result<&RobotInfo, ErrorReply> {
        let rec = self.robots.get(id).filter(|r| r.info.is_some()).ok_or_else(|| ErrorReply::not_found(format!("unknown robot {id:?}")))?;
        if !rec.alive {
            return Err(ErrorReply::conflict(format!("robot {id:?} is lost")));
        }
        rec.info.as_ref().ok_or_else(|| ErrorReply::not_found(format!("unknown robot {id:?}")))
    }

    /// What a planner needs to know about a robot.
    pub(super) fn spec(&self, id: &str) -> Option<RobotSpec> {
        let rec = self.robots.get(id)?;
        let info = rec.info.as_ref()?;
        let pose = rec.last.as_ref().map(|t| t.pose).unwrap_or_default();
        Some(RobotSpec {
            id: RobotId::from(id),
            robot_type: info.robot_type.clone(),
            x: pose.x,
            y: pose.y,
            speed: info.max_speed,
            turn_rate: info.max_turn_rate,
            reach_m: rec.last.as_ref().and_then(|t| t.battery).and_then(|b| b.reach_m),
        })
    }

    /// What a mission manager needs to know about a robot.
    pub(super) fn member(&self, id: &str) -> Option<Member> {
        let info = self.robots.get(id)?.info.as_ref()?;
        Some(Member { spec: self.spec(id)?, time_scale: info.time_scale, capabilities: info.capabilities.clone() })
    }

    /// A mission host's token appeared.
    fn host_up(&mut self, node: NodeId) {
        // Every robot node is a mission host too: its own host is news only at debug.
        if self.robots.contains_key(node.as_str()) {
            tracing::debug!(%node, "mission host up");
        } else {
            tracing::info!(%node, "mission host up");
        }
        self.hosts.insert(node);
    }

    /// A mission host's token disappeared.
    fn host_down(&mut self, node: &str) {
        if self.robots.contains_key(node) {
            tracing::debug!(%node, "mission host lost");
        } else {
            tracing::warn!(%node, "mission host lost");
        }
        self.hosts.remove(node);
    }

    pub(super) fn has_host(&self, node: &str) -> bool {
        self.hosts.contains(node)
    }

    /// The keys of the tokens of every registered robot, up or not (whose missed returns a roll
    /// call always takes).
    pub(super) fn tokens_registered(&self) -> BTreeSet<String> {
        self.robots.keys().map(|id| Key::RobotAlive(id.clone()).to_string()).collect()
    }

    /// The keys of the liveliness tokens the registry holds up: robots alive (registered or
    /// candidates) and mission hosts (what a roll call is compared with).
    pub(super) fn tokens_up(&self) -> BTreeSet<String> {
        let robots = self.robots.iter().filter(|(_, r)| r.alive).map(|(id, _)| id).chain(self.candidates.ids());
        let robots = robots.map(|id| Key::RobotAlive(id.clone()).to_string());
        robots.chain(self.hosts.iter().map(|n| Key::HostAlive(n.clone()).to_string())).collect()
    }

    /// The mission hosts alive, by node id.
    pub(super) fn hosts(&self) -> &BTreeSet<NodeId> {
        &self.hosts
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    fn info(id: &str) -> RobotInfo {
        RobotInfo::new(id, "ground", 1.0)
    }

    #[test]
    fn a_robot_appears_registers_goes_and_comes_back() {
        let mut f = Fleet::default();
        assert!(!f.registered(info("r1"), at(0.0)), "no token seen: ignored");
        assert_eq!(f.appeared("r1", at(0.0)), Appeared::Candidate { ask: true });
        assert!(!f.alive("r1") && f.get("r1").is_none(), "not in the registry before it answers");
        assert!(f.registered(info("r1"), at(0.1)));
        assert!(f.ready("r1") && f.live_robot("r1").is_ok());
        assert_eq!(f.get("r1").map(|r| r.alive_at), Some(at(0.0)), "alive since its token appeared");
        assert_eq!(f.appeared("r1", at(1.0)), Appeared::Again);
        assert!(f.disappeared("r1", at(1.5)) && !f.disappeared("r1", at(1.5)), "alive until now, then not");
        assert_eq!(f.live_robot("r1").unwrap_err(), ErrorReply::conflict("robot \"r1\" is lost"));
        assert_eq!(f.appeared("r1", at(2.0)), Appeared::Back);
        assert!(f.get("r1").is_some_and(|r| r.back && r.fresh && r.alive_at == at(2.0)));
        // A token that goes before its robot answers leaves nothing behind.
        f.appeared("ghost", at(3.0));
        f.disappeared("ghost", at(3.0));
        assert!(!f.registered(info("ghost"), at(3.1)) && f.get("ghost").is_none());
    }

    #[test]
    fn unanswered_info_queries_are_asked_again_bounded_per_tick() {
        let mut f = Fleet::default();
        for i in 0..FETCH_PER_TICK + 10 {
            let id = format!("r{i}");
            f.appeared(&id, at(0.0));
            f.registered(info(&id), at(0.0));
            f.disappeared(&id, at(0.0));
            assert_eq!(f.appeared(&id, at(0.0)), Appeared::Back);
        }
        assert!(f.fetch_due(at(0.5)).is_empty(), "asked when they appeared");
        assert_eq!(f.fetch_due(at(INFO_RETRY_S)).len(), FETCH_PER_TICK);
        assert_eq!(f.fetch_due(at(INFO_RETRY_S)).len(), 10, "the rest at the next tick");
    }

    /// Issue 50: 3 000 made-up tokens appearing and going were journaled and logged one by one;
    /// they now never enter the registry, and a real robot vouched for by its own telemetry
    /// registers first.
    #[test]
    fn made_up_tokens_never_enter_the_registry() {
        let mut f = Fleet::default();
        let mut asked = 0;
        for i in 0..10_000 {
            asked += f.handle(at(0.0), Heard::Alive(format!("ghost{i}").into())).len();
        }
        assert_eq!(asked, super::super::candidates::ASK_AT_ONCE_BELOW, "a bounded number asked at once");
        assert_eq!(f.iter().count(), 0, "none in the registry");
        let r1 = RobotId::from("r1");
        f.handle(at(0.1), Heard::Alive(r1.clone()));
        assert_eq!(seen(&mut f, at(0.2), "r1", 1, 0), vec![Fact::Fetch(r1.clone())], "its telemetry vouches for it: asked at once");
        assert_eq!(f.handle(at(0.3), Heard::Info(info("r1"))), vec![Fact::Registered(r1.clone())]);
        for i in 0..10_000 {
            assert!(f.handle(at(1.0), Heard::Gone(format!("ghost{i}").into())).is_empty(), "no loss of a ghost");
        }
        assert_eq!(f.iter().map(|(id, _)| id.clone()).collect::<Vec<_>>(), [r1]);
    }

    #[test]
    fn robots_lost_long_ago_and_in_no_mission_are_forgotten() {
        let mut f = Fleet::default();
        for id in ["r1", "r2", "r3"] {
            f.appeared(id, at(0.0));
            f.registered(info(id), at(0.0));
        }
        f.disappeared("r1", at(10.0));
        f.disappeared("r2", at(10.0));
        assert_eq!(f.forget_lost(at(100.0), 100.0, |_| false), 0, "not long enough");
        assert_eq!(f.forget_lost(at(110.0), 100.0, |id| id == "r2"), 1, "r2 is kept (in a mission)");
        assert!(f.get("r1").is_none() && f.get("r2").is_some() && f.get("r3").is_some());
        // Back, it registers again as a new robot.
        assert_eq!(f.appeared("r1", at(120.0)), Appeared::Candidate { ask: true });
    }

    #[test]
    fn a_full_registry_ignores_new_ids_and_keeps_the_known_ones() {
        let mut f = Fleet::default();
        for i in 0..MAX_FLEET {
            let id = format!("r{i}");
            f.appeared(&id, at(0.0));
            f.registered(info(&id), at(0.0));
        }
        f.appeared("intruder", at(0.0));
        assert!(!f.registered(info("intruder"), at(0.0)));
        assert!(f.get("intruder").is_none());
        f.disappeared("r0", at(0.5));
        assert_eq!(f.appeared("r0", at(1.0)), Appeared::Back, "a known robot still comes back");
    }

    fn seen(f: &mut Fleet, now: Time, id: &str, seq: u64, info_rev: u32) -> Vec<Fact> {
        let t = Telemetry { seq, info_rev, ..Telemetry::resting(id, now.secs()) };
        let facts = f.handle(now, Heard::Telemetry(Box::new(t.clone())));
        if facts.iter().any(|x| matches!(x, Fact::Heard(_))) {
            f.keep(t);
        }
        facts
    }

    /// The registry as a machine: what it hears of a robot becomes the facts the missions act on,
    /// in order — asked who it is, lost, back and asked again, newer telemetry only.
    #[test]
    fn the_registry_decides_what_a_robot_heard_of_means() {
        let mut f = Fleet::default();
        let r1 = RobotId::from("r1");
        assert_eq!(f.handle(at(0.0), Heard::Alive(r1.clone())), vec![Fact::Fetch(r1.clone())]);
        assert_eq!(f.handle(at(0.1), Heard::Info(info("r1"))), vec![Fact::Registered(r1.clone())]);
        assert!(matches!(seen(&mut f, at(0.2), "r1", 5, 0).as_slice(), [Fact::Heard(t)] if t.seq == 5));
        assert!(seen(&mut f, at(0.3), "r1", 4, 0).is_empty(), "older telemetry is not news");
        // Its info changed (a capability): asked again, once per retry period.
        assert!(matches!(seen(&mut f, at(1.5), "r1", 6, 1).as_slice(), [Fact::Fetch(id), Fact::Heard(_)] if *id == r1));
        assert!(matches!(seen(&mut f, at(1.6), "r1", 7, 1).as_slice(), [Fact::Heard(_)]));
        assert_eq!(f.handle(at(2.0), Heard::Gone(r1.clone())), vec![Fact::Lost(r1.clone())]);
        assert!(f.handle(at(2.1), Heard::Gone(r1.clone())).is_empty(), "lost once");
        assert_eq!(f.handle(at(3.0), Heard::Alive(r1.clone())), vec![Fact::Back(r1.clone()), Fact::Fetch(r1.clone())]);
        // Back, it counts again from its first telemetry (a restart starts its sequence anew).
        assert!(matches!(seen(&mut f, at(3.1), "r1", 1, 1).as_slice(), [Fact::Heard(_)]));
        assert!(f.last("r1").is_some_and(|t| t.seq == 1));
        f.handle(at(3.2), Heard::Info(info("r1")));
        // Hosts, and the tick that asks again what was not answered.
        assert!(f.handle(at(4.0), Heard::HostAlive("h1".into())).is_empty() && f.has_host("h1"));
        assert_eq!(f.handle(at(4.1), Heard::HostGone("h1".into())), vec![Fact::HostLost("h1".into())]);
        f.handle(at(4.2), Heard::Alive("r2".into()));
        assert_eq!(f.handle(at(4.2 + INFO_RETRY_S), Heard::Tick), vec![Fact::Fetch("r2".into())]);
    }

    /// A robot back whose first info answer is lost is asked again: the record from before its
    /// restart (another type, other capabilities) is not taken for its answer.
    #[test]
    fn a_robot_back_is_asked_again_until_it_answers() {
        let mut f = Fleet::default();
        let r1 = RobotId::from("r1");
        f.handle(at(0.0), Heard::Alive(r1.clone()));
        f.handle(at(0.1), Heard::Info(info("r1")));
        f.handle(at(1.0), Heard::Gone(r1.clone()));
        assert_eq!(f.handle(at(2.0), Heard::Alive(r1.clone())), vec![Fact::Back(r1.clone()), Fact::Fetch(r1.clone())]);
        assert!(f.handle(at(2.5), Heard::InfoFailed { id: r1.clone(), reason: "timeout".into() }).is_empty());
        assert_eq!(f.handle(at(2.0 + INFO_RETRY_S), Heard::Tick), vec![Fact::Fetch(r1.clone())], "asked again");
        f.handle(at(3.1), Heard::Info(info("r1")));
        assert!(f.handle(at(5.0), Heard::Tick).is_empty(), "answered: not asked again");
    }
}
