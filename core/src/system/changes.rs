//! Operator changes to a running mission: new parameters or map (checked in full with a dry-run
//! plan, like a create, before anything changes), pause and resume. The mission's definition is
//! replaced (journaled) and its head told ([`MissionCtl::Update`], re-sent until acknowledged);
//! the head replans its members as the next epoch, or holds them where they are while paused.
//! Its members stay members throughout.

use std::collections::BTreeMap;
use std::sync::Arc;

use mrmm_planner::recipe;
use mrmm_proto::{MissionCtl, MissionSpecWire, MissionUpdate, RobotId};
use serde_json::{json, Value};

use super::missions::{cheap, param_strings, DryRun};
use super::{Command, Req, SystemManager};
use crate::wire;

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
            return vec![Command::Reply { req, result: Err(format!("mission {}: {e}", u.name)) }];
        }
        let spec = match self.check_update(&u) {
            Ok((spec, _)) => spec,
            Err(e) => return vec![Command::Reply { req, result: Err(e) }],
        };
        self.note_command(&req, "mission update", &serde_json::to_value(&u).unwrap_or(Value::Null));
        let answer = self.apply_spec(&u.name, spec);
        vec![Command::Reply { req, result: Ok(answer) }]
    }

    /// The mission as it would be after `u`, and the dry run that checks it; or the first
    /// problem. Changes nothing.
    fn check_update(&self, u: &MissionUpdate) -> Result<(MissionSpecWire, DryRun), String> {
        let mut spec = self.spec_of(&u.name)?;
        let r = recipe::parse(&spec.recipe_xml).map_err(|e| format!("mission {}: its recipe: {e}", u.name))?;
        let mut given = param_strings(&u.params);
        for (team, params) in &u.teams {
            given.extend(param_strings(params).into_iter().map(|(k, v)| (format!("{team}/{k}"), v)));
        }
        for (k, v) in &given {
            recipe::check_override(&r, k, v).map_err(|e| format!("mission {}: {e}", u.name))?;
        }
        if given.is_empty() && u.map.is_none() {
            return Err(format!("mission {}: nothing to change: give parameters or a map", u.name));
        }
        spec.params.extend(given);
        let held = match u.map.as_deref() {
            // "" plans in the plane again.
            Some("") => {
                spec.map = None;
                None
            }
            Some(name) => {
                let h = self.maps.get(name).ok_or_else(|| format!("no map {name:?}"))?;
                spec.map = Some(h.map_ref());
                Some(h.map.clone())
            }
            None => spec.map.as_ref().and_then(|m| self.maps.get(&m.name).filter(|h| h.info.hash == m.hash)).map(|h| h.map.clone()),
        };
        let ids: Vec<&RobotId> = self.assignment.iter().filter(|(id, m)| *m == &u.name && self.fleet.alive(id)).map(|(id, _)| id).collect();
        let robots: Vec<_> = ids.iter().filter_map(|id| self.spec(id)).map(|s| wire::robot_spec(&s)).collect();
        let caps = ids.iter().map(|id| (id.to_string(), self.capabilities_of(id).to_vec())).collect();
        if robots.is_empty() {
            return Err(format!("mission {} has no live robot to plan for: add robots first", u.name));
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

    /// The definition of a mission this manager can change.
    fn spec_of(&self, name: &str) -> Result<MissionSpecWire, String> {
        let rec = self.missions.get(name).ok_or_else(|| format!("unknown mission {name:?}"))?;
        rec.def.spec.clone().ok_or_else(|| {
            format!("mission {name} was adopted from its head's report: this central does not know its recipe, so it cannot change it (terminate and create it again)")
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
