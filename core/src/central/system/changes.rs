//! Operator changes to a running mission: new parameters or map (checked in full with a dry-run
//! plan, like a create, before anything changes), pause and resume. The mission's definition is
//! replaced (journaled) and its head told ([`MissionCtl::Update`], re-sent until acknowledged);
//! the head replans its members as the next epoch, or holds them where they are while paused.
//! Its members stay members throughout.
//!
//! The definition is what the journal holds: a head whose reports disagree with it (central
//! acknowledged a change, then restarted before the head heard of it) is sent it again
//! ([`SystemManager::sync_spec`]) until they agree.

use std::collections::BTreeMap;
use std::sync::Arc;

use mrmm_planner::recipe;
use mrmm_proto::{ErrorReply, MissionCtl, MissionSpecWire, MissionStatus, MissionUpdate, MissionView, RobotId};
use serde_json::{json, Value};

use super::missions::{cheap, param_strings, DryRun};
use super::{Command, Req, SystemManager, SPEC_SYNC_S};

impl SystemManager {
    /// An update: checked here, dry-run planned by the driver, applied on
    /// [`SystemManager::update_checked`].
    pub(super) fn update(&mut self, req: Req, u: MissionUpdate) -> Vec<Command> {
        let dry = match self.check_update(&u) {
            Ok((_, dry)) => dry,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        let id = self.dry_runs.push(req, super::dry_runs::Checking::Update(u));
        vec![Command::DryRun(Box::new(DryRun { id, ..dry }))]
    }

    /// The dry run of an update is done: it takes effect (checked again) or its error is the
    /// answer.
    pub(super) fn update_checked(&mut self, req: Req, u: MissionUpdate, result: Result<(), String>) -> Vec<Command> {
        if let Err(e) = result {
            return vec![Command::Reply { req, result: Err(ErrorReply::invalid(format!("mission {}: {e}", u.name))) }];
        }
        let spec = match self.check_update(&u) {
            Ok((spec, _)) => spec,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        self.note_command(&req, "mission update", &serde_json::to_value(&u).unwrap_or(Value::Null));
        let answer = self.apply_spec(u.name.as_str(), spec);
        vec![Command::Reply { req, result: Ok(answer) }]
    }

    /// The mission as it would be after `u`, and the dry run that checks it; or the first
    /// problem. Changes nothing.
    fn check_update(&self, u: &MissionUpdate) -> Result<(MissionSpecWire, DryRun), ErrorReply> {
        let mut spec = self.spec_of(u.name.as_str())?;
        let r = recipe::parse(&spec.recipe_xml).map_err(|e| ErrorReply::conflict(format!("mission {}: its recipe: {e}", u.name)))?;
        let mut given = param_strings(&u.params);
        for (team, params) in &u.teams {
            given.extend(param_strings(params).into_iter().map(|(k, v)| (format!("{team}/{k}"), v)));
        }
        for (k, v) in &given {
            recipe::check_override(&r, k, v).map_err(|e| ErrorReply::invalid(format!("mission {}: {e}", u.name)))?;
        }
        if given.is_empty() && u.map.is_none() {
            return Err(ErrorReply::invalid(format!("mission {}: nothing to change: give parameters or a map", u.name)));
        }
        spec.params.extend(given);
        let held = match u.map.as_deref() {
            // "" plans in the plane again.
            Some("") => {
                spec.map = None;
                None
            }
            Some(name) => {
                let h = self.maps.get(name).ok_or_else(|| ErrorReply::not_found(format!("no map {name:?}")))?;
                spec.map = Some(h.map_ref());
                Some(h.map.clone())
            }
            // The mission's own map, by its hash (a superseded version if the file changed).
            None => spec.map.as_ref().and_then(|m| self.map_of(m)).map(|h| h.map.clone()),
        };
        let ids: Vec<&RobotId> = self.assignment.iter().filter(|(id, m)| *m == &u.name && self.fleet.alive(id.as_str())).map(|(id, _)| id).collect();
        let robots: Vec<_> = ids.iter().filter_map(|id| self.spec(id.as_str())).collect();
        let caps = ids.iter().map(|id| (id.to_string(), self.capabilities_of(id.as_str()).to_vec())).collect();
        if robots.is_empty() {
            return Err(ErrorReply::conflict(format!("mission {} has no live robot to plan for: add robots first", u.name)));
        }
        let dry = DryRun { id: 0, recipe_xml: spec.recipe_xml.clone(), params: cheap(&r, &spec.params), robots, caps, map: held };
        Ok((spec, dry))
    }

    /// Pauses (`true`) or resumes a mission.
    pub(super) fn pause(&mut self, req: Req, name: &str, paused: bool) -> Vec<Command> {
        let mut spec = match self.spec_of(name) {
            Ok(s) => s,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        let verb = if paused { "mission pause" } else { "mission resume" };
        self.note_command(&req, verb, &json!({ "name": name }));
        if spec.paused == paused {
            return vec![Command::Reply { req, result: Ok(json!({ "ok": true, "mission": name, "paused": paused, "changed": false })) }];
        }
        spec.paused = paused;
        let answer = self.apply_spec(name, spec);
        vec![Command::Reply { req, result: Ok(answer) }]
    }

    /// `name`'s head reported: if what it runs (parameters, map, paused) has disagreed with the
    /// mission's definition for [`SPEC_SYNC_S`] with no update on its way (or answered), the
    /// definition is sent again — an update, pause or resume acknowledged to the operator is
    /// carried out even if central restarted before the head heard of it. An update the head
    /// already runs changes nothing there.
    pub(super) fn sync_spec(&mut self, name: &str) {
        let now = self.now;
        let pending = self.controls.has(name, |c| matches!(c, MissionCtl::Update { .. })) || self.pending_create.contains_key(name);
        let Some(rec) = self.missions.get_mut(name) else { return };
        let (Some(spec), Some(view)) = (rec.def.spec.as_ref(), rec.view.as_ref()) else { return };
        if !disagrees(spec, view) || pending {
            rec.spec_differs_since = None;
            return;
        }
        let since = *rec.spec_differs_since.get_or_insert(now);
        if now - since < SPEC_SYNC_S {
            return;
        }
        tracing::warn!(mission = %name, paused = spec.paused, "the mission's head runs another definition than the journal's: sent it again");
        rec.spec_differs_since = None;
        let spec = spec.clone();
        self.controls.push(name, MissionCtl::Update { spec }, vec![]);
    }

    /// The definition of a mission this manager can change.
    fn spec_of(&self, name: &str) -> Result<MissionSpecWire, ErrorReply> {
        let rec = self.missions.get(name).ok_or_else(|| ErrorReply::not_found(format!("unknown mission {name:?}")))?;
        rec.def.spec.clone().ok_or_else(|| {
            ErrorReply::conflict(format!(
                "mission {name} was adopted from its head's report: this central does not know its recipe, so it cannot change it (terminate and create it again)"
            ))
        })
    }

    /// The mission is now `spec`: its definition replaced (journaled with the next event) and
    /// its head told, or its pending start changed.
    fn apply_spec(&mut self, name: &str, spec: MissionSpecWire) -> Value {
        if let Some(rec) = self.missions.get_mut(name) {
            let mut def = (*rec.def).clone();
            def.spec = Some(spec.clone());
            rec.def = Arc::new(def);
        }
        for s in self.starts.iter_mut().filter(|s| s.start.spec.name == name) {
            s.start.spec = spec.clone();
        }
        let params: BTreeMap<String, String> = spec.params.clone();
        let answer =
            json!({ "ok": true, "mission": name, "paused": spec.paused, "params": params, "map": spec.map.as_ref().map(|m| m.name.clone()), "changed": true });
        tracing::info!(mission = %name, paused = spec.paused, "mission changed by the operator");
        self.controls.push(name, MissionCtl::Update { spec }, vec![]);
        answer
    }
}

/// Whether a head's report shows another definition than `spec`: other parameters or map, or
/// running while paused (and the other way round).
fn disagrees(spec: &MissionSpecWire, view: &MissionView) -> bool {
    let paused = match view.status {
        MissionStatus::Paused => !spec.paused,
        MissionStatus::Running => spec.paused,
        _ => false,
    };
    paused || view.params != spec.params || view.map != spec.map
}
