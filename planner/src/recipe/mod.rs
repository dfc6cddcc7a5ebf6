//! XML recipes: a mission template naming its planner, its parameters and, per robot type, the
//! behaviour sequence a plan is made of. [`parse`] reads and type-checks (unknown elements and
//! attributes are errors), [`validate`] checks the meaning, [`build`] runs the planner and
//! expands the behaviour templates into robot plans. Every error names line:column. The format
//! is documented in `recipes/README.md`.

mod build;
mod dom;
mod teams;
mod wire;

use std::collections::BTreeMap;

use crate::error::PlanError;
use crate::geom::Point;
use crate::limits;

pub use build::{build, build_for, build_on, build_with, parse_overrides, MissionPlan, TeamPlan, DEFAULT_ROBOT_RADIUS};
use dom::Element;
pub use dom::Pos;
pub use teams::{assign, assign_as, Bounds, Leaf, Team, TeamBody, MAX_TEAMS, MAX_TEAM_DEPTH, RESERVED_TEAM_NAMES};

/// The recipe bank shipped in `recipes/`, embedded: (name, XML).
pub const BANK: &[(&str, &str)] = &[
    ("patrol", include_str!("../../../recipes/patrol.xml")),
    ("coverage", include_str!("../../../recipes/coverage.xml")),
    ("escort", include_str!("../../../recipes/escort.xml")),
];

/// The XML of a recipe of the bank.
pub fn bank(name: &str) -> Option<&'static str> {
    BANK.iter().find(|(n, _)| *n == name).map(|(_, x)| *x)
}

/// Which planner a recipe uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlannerKind {
    Patrol,
    Coverage,
}

impl PlannerKind {
    pub fn as_str(self) -> &'static str {
        match self {
            PlannerKind::Patrol => "patrol",
            PlannerKind::Coverage => "coverage",
        }
    }

    /// Whether the planner takes parameter `name` (a scalar, or its waypoints or region).
    pub fn takes(self, name: &str) -> bool {
        self.scalar_params().contains(&name) || matches!((self, name), (PlannerKind::Patrol, "waypoints") | (PlannerKind::Coverage, "region"))
    }

    /// Scalar parameters the planner understands.
    pub fn scalar_params(self) -> &'static [&'static str] {
        match self {
            PlannerKind::Patrol => {
                &["sync_spacing_max", "rounds", "seed", "max_kicks", "max_worst_idleness", "barrier", "robot_radius", "turn_rate", "charging"]
            }
            PlannerKind::Coverage => &["samples", "lloyd_iterations", "minimax_iterations", "seed", "robot_radius", "charging"],
        }
    }
}

/// A parsed recipe.
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    pub name: String,
    pub planner: PlannerKind,
    pub description: String,
    /// Scalar parameters: name → (value, where).
    pub params: BTreeMap<String, (String, Pos)>,
    pub waypoints: Option<(Vec<Point>, Pos)>,
    pub region: Option<(Vec<Point>, Vec<Vec<Point>>, Pos)>,
    pub behaviours: Vec<Behaviour>,
    /// Capabilities every robot of the mission must have (`<requires capability="…"/>`); in a
    /// leaf team, every robot of that team.
    pub requires: Vec<(String, Pos)>,
    pub pos: Pos,
    /// The recipe's teams (a recipe without `planner` on its root); empty: the recipe is one
    /// team, planned as a whole.
    pub teams: Vec<Team>,
    /// Where this recipe's team sits below the mission: `""` for a whole recipe, the team's
    /// path (`ground/north`) for a leaf team's.
    pub path: String,
}

/// Capabilities a recipe may require at most (a robot has at most as many).
pub const MAX_REQUIRES: usize = 32;

impl Recipe {
    fn empty(name: String, planner: PlannerKind, pos: Pos) -> Self {
        Recipe {
            name,
            planner,
            description: String::new(),
            params: BTreeMap::new(),
            waypoints: None,
            region: None,
            behaviours: Vec::new(),
            requires: Vec::new(),
            pos,
            teams: Vec::new(),
            path: String::new(),
        }
    }

    /// The capabilities every member must have, sorted (in a recipe of teams, what its root
    /// requires; each team may require more).
    pub fn required(&self) -> Vec<String> {
        let mut out: Vec<String> = self.requires.iter().map(|(c, _)| c.clone()).collect();
        out.sort();
        out.dedup();
        out
    }
}

/// Whether `name` can be a capability: 1 to 64 characters of `[A-Za-z0-9_.-]` (the rule robots
/// and the operator API apply too, `mrmm_proto::validate_capability`).
pub fn is_capability(name: &str) -> bool {
    !name.is_empty() && name.len() <= 64 && name.bytes().all(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-' | b'.'))
}

/// The behaviour sequence for one robot type (`*`: any type without its own).
#[derive(Debug, Clone, PartialEq)]
pub struct Behaviour {
    pub robot_type: String,
    pub steps: Vec<Template>,
    pub pos: Pos,
}

/// One element of a behaviour sequence.
#[derive(Debug, Clone, PartialEq)]
pub enum Template {
    Stream,
    /// Go to the robot's assigned slot (patrol) or point (coverage).
    NavigateSlot,
    /// Go to a fixed point.
    NavigateTo {
        x: f64,
        y: f64,
        speed: Option<f64>,
    },
    /// The start barrier of a team: the robot's own, its parent's or the whole mission's.
    SyncStart(Scope),
    Hold {
        seconds: Option<f64>,
    },
    /// One round of the patrol tour, with its sync points.
    Round(Pos),
    /// Repeat the body; `rounds` None: the mission's `rounds` parameter (default forever).
    Loop {
        rounds: Option<u32>,
        body: Vec<Template>,
        pos: Pos,
    },
}

/// Which team a `<sync>` waits for (`scope="team|parent|mission"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// The robot's own (leaf) team.
    Team,
    /// The team its team is in (the mission, for a top-level team).
    Parent,
    /// Every member of the mission.
    Mission,
}

impl Scope {
    /// The scope of a plan's sync step, for a robot of team `path` (below the mission): `None`
    /// its own team, `Some("")` the mission, `Some(p)` team `p`.
    pub fn resolve(self, path: &str) -> Option<String> {
        match (self, path.rsplit_once('/')) {
            (Scope::Team, _) => None,
            _ if path.is_empty() => None,
            (Scope::Mission, _) | (Scope::Parent, None) => Some(String::new()),
            (Scope::Parent, Some((parent, _))) => Some(parent.to_string()),
        }
    }
}

pub(crate) fn planner_kind(el: &Element, name: &str) -> Result<PlannerKind, PlanError> {
    match name {
        "patrol" => Ok(PlannerKind::Patrol),
        "coverage" => Ok(PlannerKind::Coverage),
        other => Err(el.pos.err(format!("unknown planner {other:?} (patrol, coverage)"))),
    }
}

/// Reads a recipe. Syntax and structure only; see [`validate`].
pub fn parse(text: &str) -> Result<Recipe, PlanError> {
    limits::at_most("recipe bytes", text.len(), limits::MAX_RECIPE_BYTES)?;
    let root = dom::parse(text)?;
    if root.name != "recipe" {
        return Err(root.pos.err(format!("root element must be <recipe>, found <{}>", root.name)));
    }
    root.only_attrs(&["name", "planner"])?;
    root.no_text()?;
    let name = root.required("name")?.to_string();
    let Some(planner) = root.attr("planner") else {
        return teams::parse_root(&root, Recipe::empty(name, PlannerKind::Patrol, root.pos));
    };
    let mut recipe = Recipe::empty(name, planner_kind(&root, planner)?, root.pos);
    let mut seen_params = false;
    for child in &root.children {
        match child.name.as_str() {
            "requires" => parse_requires(child, &mut recipe.requires)?,
            "team" => return Err(child.pos.err("a recipe with teams has no planner on its <recipe>: each leaf <team> names its own")),
            _ => parse_body(child, &mut recipe, "recipe", &mut seen_params)?,
        }
    }
    Ok(recipe)
}

/// One child of a recipe planned as a whole, or of a leaf team: description, params, behaviour.
fn parse_body(child: &Element, recipe: &mut Recipe, parent: &str, seen_params: &mut bool) -> Result<(), PlanError> {
    match child.name.as_str() {
        "description" => {
            child.only_attrs(&[])?;
            recipe.description = child.text.trim().to_string();
        }
        "params" => {
            if std::mem::replace(seen_params, true) {
                return Err(child.pos.err("<params> given twice"));
            }
            parse_params(child, recipe)?;
        }
        "behaviour" => {
            child.only_attrs(&["type"])?;
            child.no_text()?;
            let robot_type = child.required("type")?.to_string();
            let steps = child.children.iter().map(parse_template).collect::<Result<_, _>>()?;
            recipe.behaviours.push(Behaviour { robot_type, steps, pos: child.pos });
        }
        other => return Err(child.pos.err(format!("unknown element <{other}> in <{parent}> (description, requires, params, behaviour)"))),
    }
    Ok(())
}

/// `<requires capability="…"/>`.
fn parse_requires(child: &Element, requires: &mut Vec<(String, Pos)>) -> Result<(), PlanError> {
    leaf(child, &["capability"])?;
    let name = child.required("capability")?;
    if !is_capability(name) {
        return Err(child.pos.err(format!("<requires capability={name:?}>: use 1 to 64 characters of A-Z a-z 0-9 _ - .")));
    }
    if requires.iter().any(|(c, _)| c == name) {
        return Err(child.pos.err(format!("capability {name:?} required twice")));
    }
    if requires.len() >= MAX_REQUIRES {
        return Err(child.pos.err(format!("more than {MAX_REQUIRES} <requires>")));
    }
    requires.push((name.to_string(), child.pos));
    Ok(())
}

fn parse_params(el: &Element, recipe: &mut Recipe) -> Result<(), PlanError> {
    el.only_attrs(&[])?;
    el.no_text()?;
    for p in &el.children {
        match p.name.as_str() {
            "param" => {
                p.only_attrs(&["name", "value"])?;
                let name = p.required("name")?.to_string();
                let value = p.required("value")?.to_string();
                if recipe.params.insert(name.clone(), (value, p.pos)).is_some() {
                    return Err(p.pos.err(format!("parameter {name:?} given twice")));
                }
            }
            "waypoints" => {
                p.only_attrs(&[])?;
                if recipe.waypoints.is_some() {
                    return Err(p.pos.err("<waypoints> given twice"));
                }
                recipe.waypoints = Some((points(p)?, p.pos));
            }
            "region" => {
                p.only_attrs(&[])?;
                p.no_text()?;
                if recipe.region.is_some() {
                    return Err(p.pos.err("<region> given twice"));
                }
                let mut outer = None;
                let mut holes = Vec::new();
                for r in &p.children {
                    r.only_attrs(&[])?;
                    match r.name.as_str() {
                        "outer" if outer.is_none() => outer = Some(points(r)?),
                        "outer" => return Err(r.pos.err("<outer> given twice")),
                        "hole" => holes.push(points(r)?),
                        other => return Err(r.pos.err(format!("unknown element <{other}> in <region> (outer, hole)"))),
                    }
                }
                let outer = outer.ok_or_else(|| p.pos.err("<region> needs an <outer> ring"))?;
                recipe.region = Some((outer, holes, p.pos));
            }
            other => return Err(p.pos.err(format!("unknown element <{other}> in <params> (param, waypoints, region)"))),
        }
    }
    Ok(())
}

fn points(el: &Element) -> Result<Vec<Point>, PlanError> {
    el.no_text()?;
    el.children
        .iter()
        .map(|c| {
            if c.name != "point" {
                return Err(c.pos.err(format!("unknown element <{}> in <{}> (point)", c.name, el.name)));
            }
            c.only_attrs(&["x", "y"])?;
            c.no_text()?;
            Ok(Point::new(c.number("x")?, c.number("y")?))
        })
        .collect()
}

fn leaf(el: &Element, attrs: &[&str]) -> Result<(), PlanError> {
    el.only_attrs(attrs)?;
    el.no_text()?;
    if let Some(c) = el.children.first() {
        return Err(c.pos.err(format!("<{}> takes no child elements", el.name)));
    }
    Ok(())
}

fn parse_template(el: &Element) -> Result<Template, PlanError> {
    match el.name.as_str() {
        "stream" => leaf(el, &[]).map(|_| Template::Stream),
        "navigate" => {
            leaf(el, &["to", "x", "y", "speed"])?;
            match el.attr("to") {
                Some("slot") if el.attr("x").is_none() && el.attr("y").is_none() && el.attr("speed").is_none() => Ok(Template::NavigateSlot),
                Some("slot") => Err(el.pos.err("<navigate to=\"slot\"> takes no x, y or speed")),
                Some(other) => Err(el.pos.err(format!("<navigate to={other:?}>: the only target is \"slot\"; use x and y for a fixed point"))),
                None => {
                    let speed = match el.attr("speed") {
                        Some(_) => Some(el.number("speed")?).filter(|s| *s > 0.0).map(Some).ok_or_else(|| el.pos.err("speed must be positive"))?,
                        None => None,
                    };
                    Ok(Template::NavigateTo { x: el.number("x")?, y: el.number("y")?, speed })
                }
            }
        }
        "sync" => {
            leaf(el, &["point", "scope"])?;
            let scope = match el.attr("scope").unwrap_or("team") {
                "team" => Scope::Team,
                "parent" => Scope::Parent,
                "mission" => Scope::Mission,
                other => return Err(el.pos.err(format!("<sync scope={other:?}>: team, parent or mission"))),
            };
            match el.required("point")? {
                "start" => Ok(Template::SyncStart(scope)),
                other => {
                    Err(el.pos.err(format!("<sync point={other:?}>: only \"start\" can be placed by hand; the sync points of a round come with <round/>")))
                }
            }
        }
        "hold" => {
            leaf(el, &["seconds"])?;
            let seconds = match el.attr("seconds") {
                Some(_) => Some(el.number("seconds")?).filter(|s| *s >= 0.0).map(Some).ok_or_else(|| el.pos.err("seconds must be ≥ 0"))?,
                None => None,
            };
            Ok(Template::Hold { seconds })
        }
        "round" => leaf(el, &[]).map(|_| Template::Round(el.pos)),
        "loop" => {
            el.only_attrs(&["rounds"])?;
            el.no_text()?;
            let rounds = match el.attr("rounds") {
                Some(v) => Some(v.trim().parse::<u32>().map_err(|_| el.pos.err(format!("<loop rounds={v:?}>: not a whole number")))?),
                None => None,
            };
            let body = el.children.iter().map(parse_template).collect::<Result<Vec<_>, _>>()?;
            Ok(Template::Loop { rounds, body, pos: el.pos })
        }
        other => Err(el.pos.err(format!("unknown behaviour <{other}> (stream, navigate, sync, hold, round, loop)"))),
    }
}

/// Checks the meaning of a parsed recipe: known parameters with valid values, behaviours that fit
/// the planner, no empty or nested loops, one behaviour per robot type.
pub fn validate(r: &Recipe) -> Result<(), PlanError> {
    if r.has_teams() {
        for leaf in r.leaves() {
            validate(leaf.recipe)?;
        }
        return Ok(());
    }
    for (name, (value, pos)) in &r.params {
        check_param(r.planner, name, value).map_err(|m| pos.err(m))?;
    }
    if r.planner != PlannerKind::Patrol {
        if let Some((_, pos)) = &r.waypoints {
            return Err(pos.err(format!("<waypoints> is for patrol recipes, not {}", r.planner.as_str())));
        }
    }
    if r.planner != PlannerKind::Coverage {
        if let Some((_, _, pos)) = &r.region {
            return Err(pos.err(format!("<region> is for coverage recipes, not {}", r.planner.as_str())));
        }
    }
    if r.behaviours.is_empty() {
        return Err(r.pos.err("a recipe needs at least one <behaviour>"));
    }
    for (i, b) in r.behaviours.iter().enumerate() {
        if r.behaviours[..i].iter().any(|o| o.robot_type == b.robot_type) {
            return Err(b.pos.err(format!("a second <behaviour> for type {:?}", b.robot_type)));
        }
        if b.steps.is_empty() {
            return Err(b.pos.err("<behaviour> is empty"));
        }
        check_templates(r.planner, &b.steps, false)?;
    }
    Ok(())
}

fn check_templates(planner: PlannerKind, steps: &[Template], in_loop: bool) -> Result<(), PlanError> {
    for t in steps {
        match t {
            Template::Round(pos) if planner != PlannerKind::Patrol => return Err(pos.err(format!("<round/> is for patrol recipes, not {}", planner.as_str()))),
            Template::Loop { pos, .. } if in_loop => return Err(pos.err("loops cannot be nested")),
            Template::Loop { body, pos, .. } => {
                if body.is_empty() {
                    return Err(pos.err("<loop> is empty"));
                }
                check_templates(planner, body, true)?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// Checks an operator's parameter for recipe `r`: `waypoints` and `region` (read when planned),
/// a scalar one (in a recipe of teams, every leaf team whose planner knows it takes it), or
/// `<team path>/<name>` for one leaf team.
pub fn check_override(r: &Recipe, name: &str, value: &str) -> Result<(), String> {
    let leaves = r.leaves();
    let (targets, param): (Vec<&Leaf>, &str) = match name.rsplit_once('/') {
        Some((path, param)) => match leaves.iter().find(|l| l.path() == path && r.has_teams()) {
            Some(l) => (vec![l], param),
            None => {
                let known: Vec<&str> = leaves.iter().map(|l| l.path()).filter(|p| !p.is_empty()).collect();
                return Err(format!("parameter {name:?}: no leaf team {path:?} (teams: {})", if known.is_empty() { "none".into() } else { known.join(", ") }));
            }
        },
        None => (leaves.iter().collect(), name),
    };
    let planner = targets[0].recipe.planner;
    let takers: Vec<&Leaf> = targets.into_iter().filter(|l| l.recipe.planner.takes(param)).collect();
    if takers.is_empty() {
        return Err(match param {
            "waypoints" | "region" => format!("parameter {param}: not one of the {} planner's", planner.as_str()),
            _ => check_param(planner, param, value).err().unwrap_or_else(|| format!("parameter {name:?}: no team takes it")),
        });
    }
    match param {
        // Read when planned.
        "waypoints" | "region" => Ok(()),
        _ => takers.iter().try_for_each(|l| check_param(l.recipe.planner, param, value)),
    }
}

/// Checks one scalar parameter's name and value.
pub fn check_param(planner: PlannerKind, name: &str, value: &str) -> Result<(), String> {
    let v = value.trim();
    let positive = || {
        v.parse::<f64>().ok().filter(|x| x.is_finite() && *x > 0.0).map(|_| ()).ok_or_else(|| format!("parameter {name}: {value:?} is not a positive number"))
    };
    let whole = |min: u64, max: u64| {
        v.parse::<u64>()
            .ok()
            .filter(|x| (min..=max).contains(x))
            .map(|_| ())
            .ok_or_else(|| format!("parameter {name}: {value:?} is not a whole number in [{min}, {max}]"))
    };
    match (planner, name) {
        (PlannerKind::Patrol, "sync_spacing_max") => positive(),
        // How fast the team's slowest robot turns on the spot, rad/s: robots are spaced by time.
        (PlannerKind::Patrol, "turn_rate") => v
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && limits::TURN_RATES.contains(x))
            .map(|_| ())
            .ok_or_else(|| format!("parameter {name}: {value:?} is not a turn rate from 0.01 to 1000 rad/s")),
        (PlannerKind::Patrol, "rounds") if v == "forever" => Ok(()),
        (PlannerKind::Patrol, "rounds") => whole(1, u64::from(u32::MAX)),
        (PlannerKind::Patrol, "max_kicks") => whole(0, limits::MAX_KICKS),
        // The mission's standard, watched by the advising agent (robot seconds).
        (PlannerKind::Patrol, "max_worst_idleness") => positive(),
        // How the team runs its barriers (the mission manager's, not the planner's).
        (PlannerKind::Patrol, "barrier") => {
            if matches!(v, "mesh" | "leader") {
                Ok(())
            } else {
                Err(format!("parameter {name}: {value:?} is neither \"mesh\" nor \"leader\""))
            }
        }
        (PlannerKind::Coverage, "samples") => whole(100, limits::MAX_SAMPLES),
        (PlannerKind::Coverage, "lloyd_iterations" | "minimax_iterations") => whole(0, limits::MAX_ITERATIONS),
        (_, "seed") => whole(0, u64::MAX),
        // Whether central's charging policy sends the mission's robots to charge (its own, not
        // the planner's): `auto`, `ask` (the operator decides) or `off`.
        (_, "charging") => {
            if matches!(v, "auto" | "ask" | "off") {
                Ok(())
            } else {
                Err(format!("parameter {name}: {value:?} is none of \"auto\", \"ask\", \"off\""))
            }
        }
        // Obstacles of the mission's map are inflated by it (metres; at most 10).
        (_, "robot_radius") => v
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite() && (0.0..=10.0).contains(x))
            .map(|_| ())
            .ok_or_else(|| format!("parameter {name}: {value:?} is not a radius in metres from 0 to 10")),
        _ => Err(format!("unknown parameter {name:?} for the {} planner (known: {})", planner.as_str(), planner.scalar_params().join(", "))),
    }
}

#[cfg(test)]
mod tests;
