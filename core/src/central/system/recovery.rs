//! Recovery as a machine of its own: journaled missions that no live manager runs are started
//! anew as their next lineage (`mrmm_proto::chain::lineage_of`) with the members alive. A chain
//! of the old lineage still alive somewhere (with members cut off) loses wherever it meets the
//! new one, and its head is fenced when it reports (`reports.rs`). [`Recovery::handle`] looks at
//! the missions and the registry without changing them and returns [`Anew`] decisions, which the
//! missions' side carries out (journal first, then the start).

use std::collections::{BTreeMap, BTreeSet};

use mrmm_proto::{self as proto, Member, MissionName, NodeId, RobotId, Time};

use super::fleet::Fleet;
use super::{MissionRecord, DURABLE_WAIT_S, RESTART_RETRY_S, RUNNING_WAIT_S, UNCOMMITTED_WAIT_S};

/// What recovery looks at: the missions as the system manager knows them, and the registry.
pub(super) struct Look<'a> {
    pub missions: &'a BTreeMap<MissionName, MissionRecord>,
    /// Robot → mission.
    pub assignment: &'a BTreeMap<RobotId, MissionName>,
    pub fleet: &'a Fleet,
    /// Missions with a start already queued or a create waiting for its plans: left alone.
    pub busy: BTreeSet<&'a str>,
}

/// What recovery hears.
pub(super) enum Event<'a> {
    /// Time passed: which journaled missions does no live manager run?
    Tick(Look<'a>),
    /// The start of `mission` was answered: running (`ok`) or not (tried again later).
    Answered { mission: &'a str, ok: bool },
    /// The operator created or terminated `mission`: it is not recovery's any more.
    Settled(&'a str),
}

/// Why a mission is started anew.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Why {
    /// No live manager runs this mission of the journal (central restarted).
    Orphaned,
    /// No manager reported it for [`RUNNING_WAIT_S`] while central ran: its chain lost its
    /// majority.
    Silent,
    /// Its head could not commit for [`UNCOMMITTED_WAIT_S`]: its chain lost the memory of a
    /// majority of its nodes.
    Uncommitted,
}

/// What recovery decided.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Decision {
    /// Start the mission anew.
    Anew(Anew),
    /// The start answered was one of recovery's: the mission runs again, or is tried again
    /// after [`RESTART_RETRY_S`].
    Restarted,
}

/// Start `mission` anew on `host` as `lineage`, with the `members` back.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Anew {
    pub mission: MissionName,
    pub host: NodeId,
    pub members: Vec<Member>,
    pub lineage: u32,
    pub why: Why,
}

/// A journaled mission being started again (no live manager runs it).
#[derive(Debug, Clone, Copy)]
struct Restart {
    /// A start is out.
    inflight: bool,
    /// Not before this time.
    next: Time,
}

/// Journaled missions being started again, and those held for members with a state dir.
#[derive(Debug, Clone)]
pub(super) struct Recovery {
    /// When the system manager started.
    started: Time,
    /// Missions being started again.
    inflight: BTreeMap<MissionName, Restart>,
    /// Missions said to wait for members with a state dir (said once each).
    held: BTreeSet<MissionName>,
}

impl Recovery {
    pub(super) fn new(started: Time) -> Self {
        Recovery { started, inflight: BTreeMap::new(), held: BTreeSet::new() }
    }

    /// Whether `mission` is being started again from the journal (no live manager ran it).
    pub(super) fn restarting(&self, mission: &str) -> bool {
        self.inflight.contains_key(mission)
    }

    pub(super) fn handle(&mut self, now: Time, event: Event<'_>) -> Vec<Decision> {
        match event {
            Event::Tick(look) => self.orphans(now, &look).into_iter().map(Decision::Anew).collect(),
            Event::Answered { mission, ok } => {
                let Some(r) = self.inflight.get_mut(mission) else { return vec![] };
                // A journaled mission started again is never forgotten for failing: tried again.
                r.inflight = false;
                if ok {
                    self.inflight.remove(mission);
                } else {
                    r.next = now + RESTART_RETRY_S;
                }
                vec![Decision::Restarted]
            }
            Event::Settled(mission) => {
                self.inflight.remove(mission);
                vec![]
            }
        }
    }

    /// Whether `mission` may be started (again) at `now`: no start of it out, none too recent.
    fn may_start(&self, mission: &str, now: Time) -> bool {
        self.inflight.get(mission).is_none_or(|r| !r.inflight && now >= r.next)
    }

    /// Journaled missions that no live manager runs are started again as their next lineage,
    /// with the members that are back; the others rejoin as they come back. A mission some robot
    /// says it runs is left alone for [`RUNNING_WAIT_S`]: its managers may be alive somewhere, and
    /// report.
    ///
    /// So is a mission whose managers stopped reporting while this manager ran (its chain lost
    /// its majority): started anew once none reported for [`RUNNING_WAIT_S`], with the members
    /// this manager still hears. A central cut off alone hears none, and leaves every mission
    /// alone. And one whose head reports it could not commit for [`UNCOMMITTED_WAIT_S`] (its
    /// chain lost the memory of a majority of its nodes: it never commits again).
    fn orphans(&mut self, now: Time, look: &Look<'_>) -> Vec<Anew> {
        // A robot up since before the previous manager went down may replicate a mission, and
        // its chain may take over again: a new lineage wins over it wherever they meet, and its
        // head is fenced when it reports — so that does not hold a start back.
        let mut out = Vec::new();
        for (name, rec) in look.missions {
            let stuck = rec.view.as_ref().and_then(|v| v.manager.uncommitted_s).is_some_and(|s| s >= UNCOMMITTED_WAIT_S);
            let orphaned = rec.view.is_none() || now - rec.reported_at >= RUNNING_WAIT_S || stuck;
            if !orphaned || rec.def.spec.is_none() || look.busy.contains(name.as_str()) || !self.may_start(name.as_str(), now) {
                continue;
            }
            if let Some(anew) = self.anew(now, look, name, rec, stuck) {
                anew.log();
                self.inflight.insert(name.clone(), Restart { inflight: true, next: now + RESTART_RETRY_S });
                out.push(anew);
            }
        }
        out
    }

    /// Whether orphaned mission `name` is started anew now, and how.
    fn anew(&mut self, now: Time, look: &Look<'_>, name: &MissionName, rec: &MissionRecord, stuck: bool) -> Option<Anew> {
        let fleet = look.fleet;
        // A robot runs it: its managers may be alive somewhere and report soon. If none has
        // reported for this long, its chain lost its majority: the mission is started anew,
        // with those robots too (the new lineage's plans win at them).
        let runs = fleet.iter().any(|(_, r)| r.alive && r.last.as_ref().is_some_and(|t| t.mission.as_ref().map(|x| x.as_str()) == Some(name.as_str())));
        if runs && now - self.started < RUNNING_WAIT_S {
            return None;
        }
        // A member with a state dir that came up lately may bring the mission back through
        // its chain, from its disk (with its metrics): it gets the time to.
        let reforming: Vec<&RobotId> = fleet
            .iter()
            .filter(|(id, r)| r.alive && now - r.alive_at < DURABLE_WAIT_S && look.assignment.get(*id) == Some(name))
            .filter(|(_, r)| r.info.as_ref().is_some_and(|i| i.durable))
            .map(|(id, _)| id)
            .collect();
        if !reforming.is_empty() {
            if self.held.insert(name.clone()) {
                tracing::info!(mission = %name, robots = ?reforming, "members with a state dir are back: waiting for the mission's chain to come back from their disks before starting it anew");
            }
            return None;
        }
        let host = [rec.def.host.as_str(), proto::CENTRAL_HOST].into_iter().find(|h| fleet.has_host(h)).map(NodeId::from)?;
        // The members back (a member still away may be cut off with the mission's chain: the
        // new lineage's epochs are above all of that chain's, and its head is fenced when it
        // reports). The others rejoin as they come back.
        let members: Vec<Member> =
            look.assignment.iter().filter(|(id, m)| *m == name && fleet.ready(id.as_str())).filter_map(|(id, _)| fleet.member(id.as_str())).collect();
        if members.is_empty() {
            return None;
        }
        let Some(lineage) = rec.def.lineage.checked_add(1) else {
            tracing::error!(mission = %name, "started anew too many times: not started again");
            return None;
        };
        let why = match (stuck, rec.view.is_some()) {
            (true, _) => Why::Uncommitted,
            (false, true) => Why::Silent,
            (false, false) => Why::Orphaned,
        };
        Some(Anew { mission: name.clone(), host, members, lineage, why })
    }
}

impl Anew {
    fn log(&self) {
        let Anew { mission, host, lineage, .. } = self;
        let robots: Vec<&RobotId> = self.members.iter().map(|m| &m.spec.id).collect();
        match self.why {
            Why::Uncommitted => {
                tracing::warn!(%mission, %host, ?robots, lineage, "this mission's head could not commit for {UNCOMMITTED_WAIT_S} s (its chain lost the memory of a majority of its nodes): starting it again")
            }
            Why::Silent => {
                tracing::warn!(%mission, %host, ?robots, lineage, "no manager reported this mission for {RUNNING_WAIT_S} s while central ran (its chain lost its majority): starting it again")
            }
            Why::Orphaned => tracing::info!(%mission, %host, ?robots, lineage, "no live manager runs this mission of the journal: starting it again"),
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use mrmm_proto::{MissionSpecWire, MissionView, RobotInfo, Telemetry};

    use super::super::fleet::Heard;
    use super::super::MissionDef;
    use super::*;
    use crate::at;

    /// A journaled mission of `host` (no view: no manager reported it since central started).
    fn journaled(host: &str) -> BTreeMap<MissionName, MissionRecord> {
        let spec = MissionSpecWire {
            name: "p1".into(),
            recipe_name: "patrol".into(),
            recipe_xml: String::new(),
            planner: "patrol".into(),
            params: BTreeMap::new(),
            replicas: 2,
            map: None,
            paused: false,
        };
        let def = MissionDef { host: host.into(), recipe: "patrol".into(), planner: "patrol".into(), spec: Some(spec), lineage: 3 };
        BTreeMap::from([("p1".into(), MissionRecord::new(Arc::new(def), None, false, at(0.0)))])
    }

    /// Central's host up, and robots `ids` alive and registered at `now` (`durable`: with a
    /// state dir).
    fn fleet(now: Time, ids: &[&str], durable: bool) -> Fleet {
        let mut f = Fleet::default();
        f.handle(now, Heard::HostAlive(proto::CENTRAL_HOST.into()));
        for id in ids {
            f.handle(now, Heard::Alive((*id).into()));
            f.handle(now, Heard::Info(RobotInfo { durable, ..RobotInfo::new(id, "ground", 1.0) }));
        }
        f
    }

    fn tick(r: &mut Recovery, now: Time, missions: &BTreeMap<MissionName, MissionRecord>, fleet: &Fleet, busy: &[&str]) -> Vec<Decision> {
        let assignment = BTreeMap::from([("r1".into(), "p1".into()), ("r2".into(), "p1".into())]);
        let look = Look { missions, assignment: &assignment, fleet, busy: busy.iter().copied().collect() };
        r.handle(now, Event::Tick(look))
    }

    fn anew(d: &[Decision]) -> Option<&Anew> {
        match d {
            [Decision::Anew(a)] => Some(a),
            [] => None,
            other => panic!("one decision at most, got {other:?}"),
        }
    }

    #[test]
    fn a_mission_no_manager_runs_is_started_anew_once_at_a_time_and_again_after_a_failure() {
        let missions = journaled("gone-host");
        let fleet = fleet(at(0.0), &["r1", "r2"], false);
        let mut r = Recovery::new(at(0.0));
        // Its host is gone: central's own host starts it, as the next lineage, with both members.
        let d = tick(&mut r, at(5.0), &missions, &fleet, &[]);
        let a = anew(&d).expect("started anew");
        assert_eq!((a.host.as_str(), a.lineage, a.why), (proto::CENTRAL_HOST, 4, Why::Orphaned));
        assert_eq!(a.members.iter().map(|m| m.spec.id.as_str()).collect::<Vec<_>>(), ["r1", "r2"]);
        assert!(r.restarting("p1"));
        // One start out at a time.
        assert!(anew(&tick(&mut r, at(6.0), &missions, &fleet, &[])).is_none());
        // It failed: tried again, not before the retry period.
        assert_eq!(r.handle(at(7.0), Event::Answered { mission: "p1", ok: false }), [Decision::Restarted]);
        assert!(anew(&tick(&mut r, at(7.0 + RESTART_RETRY_S - 0.1), &missions, &fleet, &[])).is_none());
        assert!(anew(&tick(&mut r, at(7.0 + RESTART_RETRY_S), &missions, &fleet, &[])).is_some());
        // It runs: recovery is done with it; a start that is not recovery's is none of its business.
        assert_eq!(r.handle(at(13.0), Event::Answered { mission: "p1", ok: true }), [Decision::Restarted]);
        assert!(!r.restarting("p1"));
        assert!(r.handle(at(14.0), Event::Answered { mission: "p1", ok: true }).is_empty());
    }

    #[test]
    fn a_mission_is_left_alone_while_it_may_still_come_back_on_its_own() {
        let missions = journaled("central");
        // Busy: a start of it is already queued.
        let mut r = Recovery::new(at(0.0));
        assert!(anew(&tick(&mut r, at(5.0), &missions, &fleet(at(0.0), &["r1"], false), &["p1"])).is_none());
        // A robot says it runs it: its managers may report, for a while after central started.
        let mut f = fleet(at(0.0), &["r1"], false);
        let mut t = Telemetry::resting("r1", 1.0);
        t.mission = Some("p1".into());
        t.seq = 1;
        f.keep(t);
        assert!(anew(&tick(&mut r, at(RUNNING_WAIT_S - 0.1), &missions, &f, &[])).is_none());
        assert!(anew(&tick(&mut r, at(RUNNING_WAIT_S), &missions, &f, &[])).is_some());
        // A member with a state dir came up lately: its chain may come back from its disk.
        let mut r = Recovery::new(at(0.0));
        let f = fleet(at(10.0), &["r1"], true);
        assert!(anew(&tick(&mut r, at(10.0 + DURABLE_WAIT_S - 0.1), &missions, &f, &[])).is_none());
        assert!(anew(&tick(&mut r, at(10.0 + DURABLE_WAIT_S), &missions, &f, &[])).is_some());
        // No member back, or no host to start it on: nothing to do.
        let mut r = Recovery::new(at(0.0));
        assert!(anew(&tick(&mut r, at(5.0), &missions, &fleet(at(0.0), &[], false), &[])).is_none());
        let mut no_host = Fleet::default();
        no_host.handle(at(0.0), Heard::Alive("r1".into()));
        no_host.handle(at(0.0), Heard::Info(RobotInfo::new("r1", "ground", 1.0)));
        assert!(anew(&tick(&mut r, at(5.0), &missions, &no_host, &[])).is_none());
    }

    #[test]
    fn a_mission_whose_head_stopped_reporting_or_cannot_commit_is_started_anew_for_that_reason() {
        let mut missions = journaled("central");
        let fleet = fleet(at(0.0), &["r1"], false);
        let rec = missions.get_mut("p1").expect("journaled");
        let mut view = MissionView::running("p1", "patrol", "central", 1, &["r1"]);
        view.manager.uncommitted_s = Some(UNCOMMITTED_WAIT_S - 1.0);
        rec.view = Some(view);
        rec.reported_at = at(30.0);
        let mut r = Recovery::new(at(0.0));
        // Reported lately, committing: running.
        assert!(anew(&tick(&mut r, at(31.0), &missions, &fleet, &[])).is_none());
        let rec = missions.get_mut("p1").expect("journaled");
        if let Some(v) = rec.view.as_mut() {
            v.manager.uncommitted_s = Some(UNCOMMITTED_WAIT_S);
        }
        assert_eq!(anew(&tick(&mut r, at(31.0), &missions, &fleet, &[])).map(|a| a.why), Some(Why::Uncommitted));
        let mut r = Recovery::new(at(0.0));
        if let Some(v) = missions.get_mut("p1").and_then(|r| r.view.as_mut()) {
            v.manager.uncommitted_s = None;
        }
        assert!(anew(&tick(&mut r, at(30.0 + RUNNING_WAIT_S - 0.1), &missions, &fleet, &[])).is_none());
        assert_eq!(anew(&tick(&mut r, at(30.0 + RUNNING_WAIT_S), &missions, &fleet, &[])).map(|a| a.why), Some(Why::Silent));
    }
}
