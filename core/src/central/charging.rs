//! The charging policy, as a pure machine over what central sees of the fleet: a robot whose
//! battery falls below its threshold, or whose mission's plan left it out for want of reach,
//! leaves its mission (a fitting idle robot moved in when its team would fall below `min`), drives to the nearest free charger of its map, is plugged in on
//! arrival, and when charged is unplugged and goes back to the mission it left if that mission
//! still wants it, else to the pool. One robot per charger: a charger is reserved from the moment
//! a robot is sent to it. A robot sent to charge is never lost for it: only a lost robot gives
//! its charger up.
//!
//! Central runs it at the agent's look ([`crate::central::CentralCore`]): the commands it returns
//! are central's own moves and gotos, and the plug command of simulated robots with a battery.
//! The operator sends a robot to charge ([`Charging::charge`]) or ends its errand
//! ([`Charging::release`]).

use std::collections::BTreeMap;

use mrmm_proto::geom::Point;
use mrmm_proto::map::Charger;
use mrmm_proto::{ErrandRecord, ErrorReply, MapInfo, MissionName, MissionStatus, MissionView, RobotId, RobotStatus, RobotView, Time};

/// When robots go and charge and when they are done (Open-RMF's defaults: 0.2 and 1.0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChargingConfig {
    /// A robot below this charge (0–1) goes and charges.
    pub go_below: f64,
    /// A charging robot at or above this charge is done.
    pub done_above: f64,
}

impl Default for ChargingConfig {
    fn default() -> Self {
        // Full is 1.0 in Open-RMF; a battery model's last percent takes as long as any other.
        ChargingConfig { go_below: 0.2, done_above: 0.99 }
    }
}

/// A robot within this distance of its charger, standing, has arrived, metres.
pub const ARRIVED_M: f64 = 0.3;
/// A robot standing away from its charger is sent to it again after this long, seconds.
pub const RESEND_S: f64 = 10.0;
/// A robot plugged in says it charges within this long, seconds (its telemetry's delay).
pub const PLUG_GRACE_S: f64 = 3.0;
/// A spare moved in for a charging robot needs at least this charge.
pub const SPARE_ABOVE: f64 = 0.5;
/// A low robot and the spare sent to relieve it swap once this close, metres, and the spare no
/// farther from the end of the low robot's leg than the low robot is. The spare is sent to that
/// leg's end (sent on as the low robot starts the next), so it mostly waits there as the low
/// robot comes and takes the leg over with nothing to drive back. On a map with traffic a robot
/// held behind a standing one waits a lane segment back (at most
/// [`crate::traffic::authority::SEGMENT_M`]), within this radius. In
/// `mrmm experiment energy` (seeds 1–8) the day's worst idleness is 1.19–1.28 × its value with no
/// batteries; swapping at 3.5 m wherever the two met (the spare sent to where the low robot
/// stood) gave up to 1.36 ×, the spare driving back the part of the leg the low robot had done.
pub const MEET_M: f64 = 3.5;
/// A low robot is relieved at the latest this long after its spare was sent, seconds, or at
/// once below this share of its threshold.
pub const RELIEF_S: f64 = 300.0;
pub const RELIEF_CRITICAL: f64 = 0.5;

/// How a mission wants its robots charged (its `charging` parameter).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// The policy sends them (the default).
    #[default]
    Auto,
    /// The operator decides (`mrmm op charge`); the advising agent suggests it.
    Ask,
    /// Never sent; the agent still warns.
    Off,
}

impl Mode {
    /// Mission `m`'s mode: its `charging` parameter (checked when the mission was created or
    /// updated; anything else counts as the default).
    pub fn of(m: &MissionView) -> Mode {
        match m.params.get("charging").map(String::as_str) {
            Some("ask") => Mode::Ask,
            Some("off") => Mode::Off,
            _ => Mode::Auto,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Auto => "auto",
            Mode::Ask => "ask",
            Mode::Off => "off",
        }
    }
}

/// What the policy has a robot do.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Move the robot to a mission, or out of its mission to the pool (`to: None`): central's
    /// own move (`mrmm/system/cmd/robot/move`).
    Move { robot: RobotId, to: Option<MissionName> },
    /// The robot takes `out`'s place in mission `to` (a hand-over: `out` is freed, the robot
    /// carries on its plan from where it was, the other members go on with theirs).
    Replace { robot: RobotId, to: MissionName, out: RobotId },
    /// Drive to (x, y) on map `map` (a name central publishes): central's goto.
    Goto { robot: RobotId, map: String, x: f64, y: f64 },
    /// Start (`true`) or stop charging: the robot stands at its charger.
    Plug { robot: RobotId, on: bool },
}

/// A robot's charging errand.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Errand {
    /// The map (its name) and the charger reserved for the robot.
    pub map: String,
    pub charger: Charger,
    /// The mission it left, to go back to when charged, and how many robots it had then —
    /// counting those still away charging that no spare replaced (they are missing from it too).
    pub left: Option<(MissionName, usize)>,
    /// The idle robot moved into the mission in its place, if one was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spare: Option<RobotId>,
    pub plugged: bool,
    /// When it was last sent to the charger.
    pub sent: Time,
    /// Where it was sent from: where it goes back to when charged, unless its mission takes it
    /// back (a charged robot does not stay on the charger).
    pub from: Option<(f64, f64)>,
}

/// A spare on its way to relieve a low robot where it stood: the two swap where they meet (the
/// spare takes over the mission where the low robot is, so its manager's new plan is the old
/// one nearly unchanged), or when the low robot cannot wait any longer.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Relief {
    pub spare: RobotId,
    /// When the spare was sent.
    pub since: Time,
    /// Where it was sent: the end of the leg the low robot drove then, or where it stood.
    pub to: Point,
}

/// The policy's state: every robot's errand.
#[derive(Debug, Clone, Default)]
pub struct Charging {
    cfg: ChargingConfig,
    errands: BTreeMap<RobotId, Errand>,
    /// Low robots still at work, by the spare coming to relieve them.
    reliefs: BTreeMap<RobotId, Relief>,
    /// Robots the operator gave a mission while on their errand: not sent again until they
    /// are above the threshold once more (charged some other way).
    excused: std::collections::BTreeSet<RobotId>,
    /// Robots unplugged and sent back to the pool, until they stand again: the fleet's view
    /// shows them charging at first, then busy on the way back, but they are the best spares
    /// there are.
    returning: std::collections::BTreeSet<RobotId>,
}

/// What central sees of the fleet now.
#[derive(Debug, Clone, Copy)]
pub struct Fleet<'a> {
    pub robots: &'a [RobotView],
    pub missions: &'a [MissionView],
    pub maps: &'a [MapInfo],
}

impl Charging {
    pub fn new(cfg: ChargingConfig) -> Self {
        Charging { cfg, errands: BTreeMap::new(), reliefs: BTreeMap::new(), excused: Default::default(), returning: Default::default() }
    }

    /// The policy of a central restarted from its journal: the errands it journaled go on
    /// (each robot plugged in again where it stands at its charger, or sent there again).
    pub fn restored(cfg: ChargingConfig, now: Time, records: &BTreeMap<RobotId, ErrandRecord>) -> Self {
        let mut c = Charging::new(cfg);
        for (robot, r) in records {
            let ErrandRecord { map, charger, left, spare, from } = r.clone();
            c.errands.insert(robot.clone(), Errand { map, charger, left, spare, plugged: false, sent: now, from });
        }
        c
    }

    /// Robots on a charging errand.
    pub fn errands(&self) -> &BTreeMap<RobotId, Errand> {
        &self.errands
    }

    /// The errands as the journal keeps them.
    pub fn records(&self) -> BTreeMap<RobotId, ErrandRecord> {
        let record = |e: &Errand| ErrandRecord { map: e.map.clone(), charger: e.charger.clone(), left: e.left.clone(), spare: e.spare.clone(), from: e.from };
        self.errands.iter().map(|(id, e)| (id.clone(), record(e))).collect()
    }

    /// Low robots waiting at work for the spare coming to relieve them.
    pub fn reliefs(&self) -> &BTreeMap<RobotId, Relief> {
        &self.reliefs
    }

    /// Looks at the fleet at `now` (seconds): errands ended, robots arrived or charged, robots
    /// to send.
    pub fn handle(&mut self, now: Time, fleet: Fleet<'_>) -> Vec<Command> {
        let by_id: BTreeMap<&RobotId, &RobotView> = fleet.robots.iter().map(|r| (&r.id, r)).collect();
        // A robot lost, or gone from the registry, gives its charger up.
        self.errands.retain(|id, _| by_id.get(id).is_some_and(|r| r.status != RobotStatus::Lost));
        let go_below = self.cfg.go_below;
        // The operator's release stands while the robot would be sent again: below the threshold,
        // or held out of its mission's plan for want of reach (before, a held robot released was
        // sent again at the next look).
        self.excused.retain(|id| by_id.get(id).is_some_and(|r| r.battery.is_some_and(|b| b.charge < go_below) || held(r, fleet.missions)));
        self.adopt(now, fleet);
        let mut out = Vec::new();
        self.returning.retain(|id| by_id.get(id).is_some_and(|r| r.status == RobotStatus::Busy && r.mission.is_none()));
        let ids: Vec<RobotId> = self.errands.keys().cloned().collect();
        for id in ids {
            self.follow(now, by_id[&id], fleet, &mut out);
        }
        // Robots of a mission that charges on the operator's word, or never, are not sent.
        let auto = |r: &RobotView| mission_of(r, fleet.missions).is_none_or(|m| Mode::of(m) == Mode::Auto);
        let mut low: Vec<&RobotView> = fleet.robots.iter().filter(|r| self.needs_charge(r, fleet) && auto(r)).collect();
        // A relief for a robot that no longer needs one (charged some other way, lost) is over.
        self.reliefs.retain(|id, _| low.iter().any(|r| &r.id == id));
        // The emptiest first when chargers are short.
        low.sort_by(|a, b| charge(a).total_cmp(&charge(b)).then(a.id.cmp(&b.id)));
        for r in low {
            self.send(now, r, fleet, &mut out);
        }
        out
    }

    /// Robots charging at a charger that no errand holds (a central that restarted lost its
    /// errands; the robots kept charging): their errands again, plugged, so that they are let go
    /// when charged and nobody else is sent to their charger.
    fn adopt(&mut self, now: Time, fleet: Fleet<'_>) {
        for r in fleet.robots.iter().filter(|r| r.status != RobotStatus::Lost && r.mission.is_none()) {
            let (Some(b), Some(p)) = (r.battery, r.pose) else { continue };
            if !b.charging || self.errands.contains_key(&r.id) {
                continue;
            }
            let at = fleet.maps.iter().filter(|m| !m.superseded).find_map(|m| {
                let c = m.chargers.iter().find(|c| away(p, c) <= ARRIVED_M && !self.taken(&m.name, c))?;
                Some((m.name.clone(), c.clone()))
            });
            if let Some((map, charger)) = at {
                tracing::info!(robot = %r.id, charger = %charger.name, "charging: a robot charging at a charger, taken back as an errand");
                self.errands.insert(r.id.clone(), Errand { map, charger, left: None, spare: None, plugged: true, sent: now, from: None });
            }
        }
    }

    /// Robots away charging from mission `m` that no spare replaced: the mission misses them.
    fn away_from(&self, m: &MissionName) -> usize {
        self.errands.values().filter(|e| e.spare.is_none() && e.left.as_ref().is_some_and(|(l, _)| l == m)).count()
    }

    /// Whether charger `c` of map `map` is reserved for a robot.
    fn taken(&self, map: &str, c: &Charger) -> bool {
        self.errands.values().any(|e| e.map == map && e.charger.name == c.name)
    }

    /// Whether `r` should go and charge: below the threshold, or held out of its mission's plan
    /// for want of reach ([`held`]), and not charging, sent, or let off by the operator.
    fn needs_charge(&self, r: &RobotView, fleet: Fleet<'_>) -> bool {
        r.status != RobotStatus::Lost
            && !self.errands.contains_key(&r.id)
            && !self.excused.contains(&r.id)
            && r.battery.is_some_and(|b| !b.charging && (b.charge < self.cfg.go_below || held(r, fleet.missions)))
    }

    /// An errand under way: plugged in on arrival, sent again if it stands elsewhere, back to
    /// work once charged.
    fn follow(&mut self, now: Time, r: &RobotView, fleet: Fleet<'_>, out: &mut Vec<Command>) {
        let Some(e) = self.errands.get_mut(&r.id) else { return };
        if r.mission.is_some() {
            // The operator (or central) gave it a mission meanwhile: their word goes.
            if e.plugged {
                out.push(Command::Plug { robot: r.id.clone(), on: false });
            }
            self.errands.remove(&r.id);
            self.excused.insert(r.id.clone());
            return;
        }
        let standing = r.behaviour.as_deref().is_none_or(|b| b == "hold");
        let near = r.pose.is_some_and(|p| away(p, &e.charger) <= ARRIVED_M);
        if !e.plugged {
            if near && standing {
                e.plugged = true;
                e.sent = now;
                out.push(Command::Plug { robot: r.id.clone(), on: true });
            } else if standing && now - e.sent >= RESEND_S {
                e.sent = now;
                out.push(Command::Goto { robot: r.id.clone(), map: e.map.clone(), x: e.charger.at.x, y: e.charger.at.y });
            }
            return;
        }
        if r.battery.is_some_and(|b| b.charge >= self.cfg.done_above) {
            if let Some(e) = self.errands.remove(&r.id) {
                let cmds = back_to_work(r, e, fleet);
                if !cmds.iter().any(|c| matches!(c, Command::Move { .. })) {
                    self.returning.insert(r.id.clone());
                }
                out.extend(cmds);
            }
            return;
        }
        // Plugged in, yet it says it is not charging: something else unplugged it (traffic had
        // it make way, a goal of its own): plugged in again where it stands, else sent back.
        if r.battery.is_some_and(|b| !b.charging) && now - e.sent >= PLUG_GRACE_S {
            tracing::info!(robot = %r.id, charger = %e.charger.name, "charging: unplugged by something else; plugged in again");
            e.plugged = false;
            e.sent = now - RESEND_S;
        }
    }

    /// Sends a low robot to the nearest free charger of its map, out of its mission, a spare in
    /// its place where its team would fall short; none free: it waits (the next look tries again).
    fn send(&mut self, now: Time, r: &RobotView, fleet: Fleet<'_>, out: &mut Vec<Command>) {
        if !self.relieved(now, r, fleet, out) {
            return;
        }
        let spare = self.reliefs.get(&r.id).map(|rel| rel.spare.clone());
        match self.dispatch(now, r, fleet, spare, out) {
            Ok(_) => {
                self.reliefs.remove(&r.id);
            }
            Err(why) => tracing::debug!(robot = %r.id, "charging: not sent yet: {why}"),
        }
    }

    /// Whether low robot `r` may leave now: it is in no mission, or no spare can come (it goes
    /// and its mission does without it), or its spare has met it ([`MEET_M`]), or it waited
    /// [`RELIEF_S`], or it is below [`RELIEF_CRITICAL`] of its threshold. Else a spare is sent
    /// to where its leg ends (where it stands, standing; sent on as it starts a new leg), and it
    /// works on meanwhile.
    fn relieved(&mut self, now: Time, r: &RobotView, fleet: Fleet<'_>, out: &mut Vec<Command>) -> bool {
        let by_id = |id: &RobotId| fleet.robots.iter().find(|v| &v.id == id);
        // A spare lost, or given other work meanwhile, relieves nobody (on its way it is busy).
        if let Some(rel) = self.reliefs.get(&r.id) {
            let ready = by_id(&rel.spare).is_some_and(|s| s.status != RobotStatus::Lost && s.mission.is_none() && !self.errands.contains_key(&s.id));
            if !ready {
                self.reliefs.remove(&r.id);
            }
        }
        let Some(m) = mission_of(r, fleet.missions) else { return true };
        // Held out of the plan, it does no work a spare must take over where it stands.
        if charge(r) < RELIEF_CRITICAL * self.cfg.go_below || held(r, fleet.missions) {
            return true;
        }
        let (Some(map), Some(p)) = (map_of(Some(m), fleet.maps), r.pose) else { return true };
        // The spare waits where the low robot's leg ends: the low robot drives on to it, and the
        // spare takes that leg over with nothing left to drive back.
        let here = p.point();
        let to = r.goal.unwrap_or(here);
        if let Some(rel) = self.reliefs.get_mut(&r.id) {
            // Close, and no farther from where the low robot drives than it is: the spare
            // drives none of the leg back.
            let met = match by_id(&rel.spare).and_then(|s| s.pose).map(|s| s.point()) {
                Some(a) => a.dist(here) <= MEET_M && r.goal.is_none_or(|g| g.dist(a) <= g.dist(here)),
                None => true,
            };
            if met || now - rel.since >= RELIEF_S {
                return true;
            }
            if rel.to.dist(to) > ARRIVED_M {
                out.push(Command::Goto { robot: rel.spare.clone(), map: map.name.clone(), x: to.x, y: to.y });
                rel.to = to;
            }
            return false;
        }
        let Some(spare) = self.spare(fleet, m, r) else { return true };
        if self.charger_free(map) {
            out.push(Command::Goto { robot: spare.clone(), map: map.name.clone(), x: to.x, y: to.y });
            self.reliefs.insert(r.id.clone(), Relief { spare, since: now, to });
        }
        false
    }

    /// Whether map `map` has a charger no robot holds.
    fn charger_free(&self, map: &MapInfo) -> bool {
        map.chargers.iter().any(|c| !self.taken(&map.name, c))
    }

    /// Sends `r` to the nearest free charger of its map; why not, if it cannot.
    fn dispatch(&mut self, now: Time, r: &RobotView, fleet: Fleet<'_>, relief: Option<RobotId>, out: &mut Vec<Command>) -> Result<Charger, String> {
        let mission = mission_of(r, fleet.missions);
        let map = map_of(mission, fleet.maps).ok_or_else(|| match mission {
            Some(m) => format!("mission {} is on no map with chargers", m.name),
            None => "it is in no mission, and central has not exactly one map with chargers".to_string(),
        })?;
        let pose = r.pose.ok_or("it has not said where it is")?;
        let nearest = map.chargers.iter().filter(|c| !self.taken(&map.name, c)).min_by(|a, b| away(pose, a).total_cmp(&away(pose, b)));
        let charger = nearest.cloned().ok_or_else(|| format!("every charger of map {} is taken", map.name))?;
        let mut spare = None;
        if let Some(m) = mission {
            spare = relief.or_else(|| self.spare(fleet, m, r));
            if held(r, fleet.missions) {
                // Its plan was a hold: the spare joins and the mission replans with it, rather
                // than taking that hold over.
                out.push(Command::Move { robot: r.id.clone(), to: None });
                out.extend(spare.iter().map(|s| Command::Move { robot: s.clone(), to: Some(m.name.clone()) }));
            } else {
                out.push(match &spare {
                    Some(s) => Command::Replace { robot: s.clone(), to: m.name.clone(), out: r.id.clone() },
                    None => Command::Move { robot: r.id.clone(), to: None },
                });
            }
        }
        out.push(Command::Goto { robot: r.id.clone(), map: map.name.clone(), x: charger.at.x, y: charger.at.y });
        let left = mission.map(|m| (m.name.clone(), m.robots.len() + self.away_from(&m.name)));
        self.excused.remove(&r.id);
        let from = Some((pose.x, pose.y));
        let errand = Errand { map: map.name.clone(), charger: charger.clone(), left, spare, plugged: false, sent: now, from };
        self.errands.insert(r.id.clone(), errand);
        Ok(charger)
    }

    /// The operator sends `robot` to charge now, whatever its charge: the charger it goes to and
    /// what to do, or why it cannot.
    pub fn charge(&mut self, now: Time, robot: &str, fleet: Fleet<'_>) -> Result<(Errand, Vec<Command>), ErrorReply> {
        let r = fleet.robots.iter().find(|r| r.id == robot).ok_or_else(|| ErrorReply::not_found(format!("unknown robot {robot:?}")))?;
        if r.status == RobotStatus::Lost {
            return Err(ErrorReply::conflict(format!("robot {robot} is lost")));
        }
        if r.battery.is_none() {
            return Err(ErrorReply::conflict(format!("robot {robot} reports no battery")));
        }
        if let Some(e) = self.errands.get(&r.id) {
            return Err(ErrorReply::conflict(format!("robot {robot} is charging at {} already (or on its way)", e.charger.name)));
        }
        let mut out = Vec::new();
        self.reliefs.remove(&r.id);
        self.dispatch(now, r, fleet, None, &mut out).map_err(|why| ErrorReply::conflict(format!("robot {robot} cannot go and charge: {why}")))?;
        Ok((self.errands[&r.id].clone(), out))
    }

    /// The operator ends `robot`'s errand: unplugged, back to the mission it left if that
    /// mission is short of it, else to where it came from; not sent again while its charge stays
    /// below the threshold.
    pub fn release(&mut self, robot: &str, fleet: Fleet<'_>) -> Result<Vec<Command>, ErrorReply> {
        let e = self.errands.remove(robot).ok_or_else(|| ErrorReply::conflict(format!("robot {robot} is on no charging errand")))?;
        let id = RobotId::from(robot);
        let out = match fleet.robots.iter().find(|r| r.id == robot) {
            Some(r) => back_to_work(r, e, fleet),
            None => vec![],
        };
        self.excused.insert(id);
        Ok(out)
    }

    /// An idle robot, charged enough and on no errand, to take the place of `leaving` in
    /// mission `m`: in a recipe of teams, when its team falls below `min` without it, one that
    /// fits the team; in a mission of one team, always (the mission keeps its count), one of the
    /// same type.
    fn spare(&self, fleet: Fleet<'_>, m: &MissionView, leaving: &RobotView) -> Option<RobotId> {
        let (robot_type, requires) = if m.team_views.is_empty() {
            (Some(&leaving.robot_type), &[][..])
        } else {
            let team = m.team_views.iter().find(|t| t.members.contains(&leaving.id))?;
            if team.members.len() > team.min {
                return None;
            }
            (team.robot_type.as_ref(), &team.requires[..])
        };
        let fit = |r: &&RobotView| {
            let back = self.returning.contains(&r.id);
            (r.status == RobotStatus::Idle || back)
                && !self.errands.contains_key(&r.id)
                && !self.reliefs.values().any(|rel| rel.spare == r.id)
                && r.battery.is_none_or(|b| (!b.charging || back) && b.charge >= SPARE_ABOVE)
                && fits(r, robot_type, requires)
                && mrmm_proto::lacking(&r.capabilities, &m.requires).is_empty()
        };
        fleet.robots.iter().filter(fit).max_by(|a, b| charge(a).total_cmp(&charge(b)).then(b.id.cmp(&a.id))).map(|r| r.id.clone())
    }
}

/// An errand over: unplugged (if it was), back to the mission it left if that mission is short
/// of a robot like it, else back where it came from.
fn back_to_work(r: &RobotView, e: Errand, fleet: Fleet<'_>) -> Vec<Command> {
    let mut out = Vec::new();
    if e.plugged {
        out.push(Command::Plug { robot: r.id.clone(), on: false });
    }
    match e.left.and_then(|(m, had)| fleet.missions.iter().find(|v| v.name == m).filter(|m| wants(m, r, had))) {
        Some(m) => out.push(Command::Move { robot: r.id.clone(), to: Some(m.name.clone()) }),
        None => {
            if let Some((x, y)) = e.from {
                out.push(Command::Goto { robot: r.id.clone(), map: e.map, x, y });
            }
        }
    }
    out
}

/// Whether `r` is of `robot_type` (if one) and has every capability of `requires`.
fn fits(r: &RobotView, robot_type: Option<&String>, requires: &[String]) -> bool {
    robot_type.is_none_or(|ty| *ty == r.robot_type) && mrmm_proto::lacking(&r.capabilities, requires).is_empty()
}

/// How far `p` is from charger `c`, metres.
fn away(p: mrmm_proto::Pose, c: &Charger) -> f64 {
    (p.x - c.at.x).hypot(p.y - c.at.y)
}

/// The mission robot `r` is in, as central sees it.
pub(crate) fn mission_of<'a>(r: &RobotView, missions: &'a [MissionView]) -> Option<&'a MissionView> {
    r.mission.as_ref().and_then(|m| missions.iter().find(|v| &v.name == m))
}

/// Whether `r`'s mission left it out of its plan for want of reach (`MissionView::held`).
fn held(r: &RobotView, missions: &[MissionView]) -> bool {
    mission_of(r, missions).is_some_and(|m| m.held.contains(&r.id))
}

/// A robot's charge, full when it has no battery.
fn charge(r: &RobotView) -> f64 {
    r.battery.map_or(1.0, |b| b.charge)
}

/// The map a robot charges on: its mission's; a robot in none, the only map with chargers.
fn map_of<'a>(mission: Option<&MissionView>, maps: &'a [MapInfo]) -> Option<&'a MapInfo> {
    let current = |m: &&MapInfo| !m.superseded && !m.chargers.is_empty();
    match mission.and_then(|m| m.map.as_ref()) {
        Some(r) => maps.iter().filter(current).find(|m| m.hash == r.hash),
        None if mission.is_some() => None,
        None => {
            let mut with = maps.iter().filter(current);
            let only = with.next();
            with.next().map_or(only, |_| None)
        }
    }
}

/// Whether mission `m` still runs and is short of a robot like `r`: a team of it below its
/// `min` that `r` fits, or, a mission of one team, fewer robots than the `had` it had.
fn wants(m: &MissionView, r: &RobotView, had: usize) -> bool {
    let short = if m.team_views.is_empty() {
        m.robots.len() < had
    } else {
        m.team_views.iter().any(|t| t.members.len() < t.min && fits(r, t.robot_type.as_ref(), &t.requires))
    };
    matches!(m.status, MissionStatus::Running | MissionStatus::Stalled) && mrmm_proto::lacking(&r.capabilities, &m.requires).is_empty() && short
}

#[cfg(test)]
mod tests;
