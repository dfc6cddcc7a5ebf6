//! Team trees: a recipe whose `<team>`s nest, each leaf team with its own planner, parameters
//! and behaviours, and which robots go to which leaf (by type and capabilities, within each
//! leaf's `min` and `max`).

use std::collections::BTreeMap;

use pathfinding::directed::edmonds_karp::edmonds_karp_sparse;

use super::dom::{Element, Pos};
use super::{is_capability, parse_body, parse_requires, planner_kind, Recipe};
use crate::error::PlanError;
use mrmm_proto::plan::RobotSpec;

/// Teams nest at most this deep below the mission (the protocol's `MAX_TEAM_DEPTH`).
pub const MAX_TEAM_DEPTH: usize = 8;
/// Teams a recipe may have at most, counting every level.
pub const MAX_TEAMS: usize = 64;
/// Words the network's keys use after a team path: no team may be named so.
pub const RESERVED_TEAM_NAMES: [&str; 4] = ["sync", "arrive", "release", "member"];

/// One team of a recipe.
#[derive(Debug, Clone, PartialEq)]
pub struct Team {
    pub name: String,
    /// Its path below the mission (`ground/north`).
    pub path: String,
    /// Only robots of this type (`type="…"`).
    pub robot_type: Option<String>,
    /// Capabilities its members must have.
    pub requires: Vec<(String, Pos)>,
    pub body: TeamBody,
    pub pos: Pos,
}

/// What a team is made of.
#[derive(Debug, Clone, PartialEq)]
pub enum TeamBody {
    /// A leaf team: a planner, its parameters and behaviours (the recipe's `path` is the team's),
    /// and how many members it takes.
    Leaf { recipe: Box<Recipe>, min: usize, max: Option<usize> },
    /// Teams inside it.
    Inner(Vec<Team>),
}

/// A leaf team as planning sees it: its recipe, bounds, and what its members must be (the types
/// and capabilities of the leaf, its ancestors and the recipe's root).
#[derive(Debug, Clone)]
pub struct Leaf<'a> {
    pub recipe: &'a Recipe,
    pub min: usize,
    pub max: Option<usize>,
    pub types: Vec<&'a str>,
    pub requires: Vec<&'a str>,
}

impl Leaf<'_> {
    /// The team's path below the mission (`""`: a recipe without teams).
    pub fn path(&self) -> &str {
        &self.recipe.path
    }

    /// Whether a robot of `robot_type` with `caps` may be a member.
    pub fn fits(&self, robot_type: &str, caps: &[String]) -> bool {
        self.types.iter().all(|t| *t == robot_type) && self.requires.iter().all(|c| caps.iter().any(|h| h == c))
    }

    /// In words, what a member must be.
    pub fn wants(&self) -> String {
        let mut w = Vec::new();
        if let Some(t) = self.types.first() {
            w.push(format!("type {t}"));
        }
        if !self.requires.is_empty() {
            w.push(format!("capabilities {}", self.requires.join(", ")));
        }
        if w.is_empty() {
            "any robot".into()
        } else {
            w.join(" and ")
        }
    }
}

impl Recipe {
    /// Whether the recipe is a tree of teams (no `planner` on its root).
    pub fn has_teams(&self) -> bool {
        !self.teams.is_empty()
    }

    /// The leaf teams in document order; a recipe without teams is its own single leaf.
    pub fn leaves(&self) -> Vec<Leaf<'_>> {
        let root: Vec<&str> = self.requires.iter().map(|(c, _)| c.as_str()).collect();
        if !self.has_teams() {
            return vec![Leaf { recipe: self, min: 0, max: None, types: vec![], requires: root }];
        }
        let mut out = Vec::new();
        collect(&self.teams, &[], &root, &mut out);
        out
    }

    /// Every team path of the tree, parents before children (empty for a recipe without teams).
    pub fn team_paths(&self) -> Vec<&str> {
        fn walk<'a>(teams: &'a [Team], out: &mut Vec<&'a str>) {
            for t in teams {
                out.push(&t.path);
                if let TeamBody::Inner(inner) = &t.body {
                    walk(inner, out);
                }
            }
        }
        let mut out = Vec::new();
        walk(&self.teams, &mut out);
        out
    }
}

fn collect<'a>(teams: &'a [Team], types: &[&'a str], requires: &[&'a str], out: &mut Vec<Leaf<'a>>) {
    for t in teams {
        let mut types = types.to_vec();
        types.extend(t.robot_type.as_deref());
        let mut requires = requires.to_vec();
        requires.extend(t.requires.iter().map(|(c, _)| c.as_str()));
        match &t.body {
            TeamBody::Leaf { recipe, min, max } => out.push(Leaf { recipe, min: *min, max: *max, types, requires }),
            TeamBody::Inner(inner) => collect(inner, &types, &requires, out),
        }
    }
}

/// Reads the root of a recipe of teams (`<recipe name>` without a planner).
pub(super) fn parse_root(root: &Element, mut recipe: Recipe) -> Result<Recipe, PlanError> {
    let mut count = 0;
    for child in &root.children {
        match child.name.as_str() {
            "description" => {
                child.only_attrs(&[])?;
                recipe.description = child.text.trim().to_string();
            }
            "requires" => parse_requires(child, &mut recipe.requires)?,
            "team" => {
                let t = parse_team(child, "", 1, &mut count)?;
                if recipe.teams.iter().any(|o| o.name == t.name) {
                    return Err(child.pos.err(format!("a second team named {:?} here", t.name)));
                }
                recipe.teams.push(t);
            }
            "params" | "behaviour" => {
                return Err(child.pos.err(format!("<{}> belongs in a leaf <team> (one with a planner) when the recipe has teams", child.name)))
            }
            other => return Err(child.pos.err(format!("unknown element <{other}> in <recipe> (description, requires, team)"))),
        }
    }
    if recipe.teams.is_empty() {
        return Err(root.pos.err("a recipe needs a planner=\"…\" or at least one <team>"));
    }
    recipe.planner = recipe.leaves()[0].recipe.planner;
    Ok(recipe)
}

fn parse_team(el: &Element, parent: &str, depth: usize, count: &mut usize) -> Result<Team, PlanError> {
    el.only_attrs(&["name", "planner", "type", "min", "max"])?;
    el.no_text()?;
    *count += 1;
    if *count > MAX_TEAMS {
        return Err(el.pos.err(format!("more than {MAX_TEAMS} teams")));
    }
    if depth > MAX_TEAM_DEPTH {
        return Err(el.pos.err(format!("teams nest at most {MAX_TEAM_DEPTH} deep")));
    }
    let name = team_name(el)?;
    let path = if parent.is_empty() { name.clone() } else { format!("{parent}/{name}") };
    let robot_type = match el.attr("type") {
        Some(t) if is_capability(t) && !t.contains('.') => Some(t.to_string()),
        Some(t) => return Err(el.pos.err(format!("<team type={t:?}>: a robot type is 1 to 64 characters of A-Z a-z 0-9 _ -"))),
        None => None,
    };
    let mut requires = Vec::new();
    let body = match el.attr("planner") {
        Some(p) => leaf(el, &name, &path, p, &mut requires)?,
        None => inner(el, &name, &path, depth, count, &mut requires)?,
    };
    Ok(Team { name, path, robot_type, requires, body, pos: el.pos })
}

/// A team's `name`: one key chunk, not a word of the network's keys.
fn team_name(el: &Element) -> Result<String, PlanError> {
    let name = el.required("name")?.to_string();
    let id_ok = !name.is_empty() && name.len() <= 64 && name.bytes().all(|c| c.is_ascii_alphanumeric() || matches!(c, b'_' | b'-'));
    if !id_ok {
        return Err(el.pos.err(format!("<team name={name:?}>: use 1 to 64 characters of A-Z a-z 0-9 _ -")));
    }
    if RESERVED_TEAM_NAMES.contains(&name.as_str()) {
        return Err(el.pos.err(format!("<team name={name:?}>: {} are words of the network's keys, not team names", RESERVED_TEAM_NAMES.join(", "))));
    }
    Ok(name)
}

/// A leaf team (it has a planner): its recipe, and how many robots it takes.
fn leaf(el: &Element, name: &str, path: &str, planner: &str, requires: &mut Vec<(String, Pos)>) -> Result<TeamBody, PlanError> {
    let bound = |a: &str| -> Result<Option<usize>, PlanError> {
        el.attr(a)
            .map(|v| {
                v.trim().parse::<usize>().ok().filter(|n| *n <= 100_000).ok_or_else(|| el.pos.err(format!("<team {a}={v:?}>: not a whole number up to 100000")))
            })
            .transpose()
    };
    let (min, max) = (bound("min")?, bound("max")?);
    let mut recipe = Recipe::empty(name.to_string(), planner_kind(el, planner)?, el.pos);
    recipe.path = path.to_string();
    let mut seen_params = false;
    for child in &el.children {
        match child.name.as_str() {
            "team" => return Err(child.pos.err(format!("team {name:?} has a planner, so it is a leaf: teams go in a team without one"))),
            "requires" => parse_requires(child, requires)?,
            _ => parse_body(child, &mut recipe, "team", &mut seen_params)?,
        }
    }
    if let (Some(lo), Some(hi)) = (min, max) {
        if lo > hi {
            return Err(el.pos.err(format!("team {name:?}: min {lo} is above max {hi}")));
        }
    }
    if max == Some(0) {
        return Err(el.pos.err(format!("team {name:?}: max must be at least 1")));
    }
    Ok(TeamBody::Leaf { recipe: Box::new(recipe), min: min.unwrap_or(0), max })
}

/// A team of teams (no planner): the teams inside it.
fn inner(el: &Element, name: &str, path: &str, depth: usize, count: &mut usize, requires: &mut Vec<(String, Pos)>) -> Result<TeamBody, PlanError> {
    if el.attr("min").is_some() || el.attr("max").is_some() {
        return Err(el.pos.err(format!("team {name:?}: min and max belong to leaf teams (those with a planner)")));
    }
    let mut inner: Vec<Team> = Vec::new();
    for child in &el.children {
        match child.name.as_str() {
            "requires" => parse_requires(child, requires)?,
            "team" => {
                let t = parse_team(child, path, depth + 1, count)?;
                if inner.iter().any(|o| o.name == t.name) {
                    return Err(child.pos.err(format!("a second team named {:?} in team {name:?}", t.name)));
                }
                inner.push(t);
            }
            "params" | "behaviour" => {
                return Err(child.pos.err(format!("<{}> in team {name:?}, which has no planner: give it planner=\"…\" or put teams inside", child.name)))
            }
            other => return Err(child.pos.err(format!("unknown element <{other}> in <team> (requires, team; a leaf team: requires, params, behaviour)"))),
        }
    }
    if inner.is_empty() {
        return Err(el.pos.err(format!("team {name:?} has neither a planner nor teams inside")));
    }
    Ok(TeamBody::Inner(inner))
}

/// Which robots go to which leaf team: for each leaf of [`Recipe::leaves`], the indexes of its
/// robots in `robots`. Every robot goes to a leaf it fits; every leaf gets its `min` (found as a
/// maximum flow, so a robot that fits several leaves goes where it is needed), then the others go,
/// those with the fewest choices first, to the least filled leaf they fit below its `max`.
/// `caps`: the robots' capabilities by id (a robot without an entry has none).
pub fn assign(r: &Recipe, robots: &[RobotSpec], caps: &BTreeMap<String, Vec<String>>) -> Result<Vec<Vec<usize>>, PlanError> {
    assign_as(r, robots, caps, Bounds::Strict)
}

/// Whether a team's `min` and `max` refuse an assignment ([`Bounds::Strict`]: a create, an
/// update) or are met as far as the robots allow ([`Bounds::Relaxed`]: a running mission
/// replanned after a loss keeps going with the members it has; the advising agent says which
/// team is short).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bounds {
    Strict,
    Relaxed,
}

/// [`assign`], with the teams' bounds applied as `bounds` says.
pub fn assign_as(r: &Recipe, robots: &[RobotSpec], caps: &BTreeMap<String, Vec<String>>, bounds: Bounds) -> Result<Vec<Vec<usize>>, PlanError> {
    let leaves = r.leaves();
    let none = Vec::new();
    let fits: Vec<Vec<usize>> = robots
        .iter()
        .map(|rb| {
            let c = caps.get(rb.id.as_str()).unwrap_or(&none);
            (0..leaves.len()).filter(|&l| leaves[l].fits(&rb.robot_type, c)).collect()
        })
        .collect();
    if let Some(i) = fits.iter().position(Vec::is_empty) {
        let rb = &robots[i];
        let wants: Vec<String> = leaves.iter().map(|l| format!("{} wants {}", show(l.path()), l.wants())).collect();
        return Err(PlanError::Invalid(format!("robot {} (type {}) fits no team of recipe {}: {}", rb.id, rb.robot_type, r.name, wants.join("; "))));
    }
    let mut out: Vec<Vec<usize>> = vec![Vec::new(); leaves.len()];
    let mut placed = vec![false; robots.len()];
    let needed: usize = leaves.iter().map(|l| l.min).sum();
    if needed > 0 {
        let wants: Vec<usize> = leaves.iter().map(|l| l.min).collect();
        let (matched, total) = min_flow(&fits, &wants, &placed);
        if total < needed {
            if bounds == Bounds::Strict {
                return Err(short(r, &leaves, &fits, robots.len(), needed, total));
            }
            // Short of robots: every team short gets one more in turn, as far as they go.
            loop {
                let one: Vec<usize> = (0..leaves.len()).map(|l| usize::from(out[l].len() < leaves[l].min)).collect();
                let (m, got) = min_flow(&fits, &one, &placed);
                if got == 0 {
                    break;
                }
                for (i, l) in m {
                    out[l].push(i);
                    placed[i] = true;
                }
            }
        } else {
            for (i, l) in matched {
                out[l].push(i);
                placed[i] = true;
            }
        }
    }
    let mut rest: Vec<usize> = (0..robots.len()).filter(|&i| !placed[i]).collect();
    rest.sort_by_key(|&i| (fits[i].len(), i));
    for i in rest {
        let room = |l: usize| bounds == Bounds::Relaxed || leaves[l].max.is_none_or(|m| out[l].len() < m);
        let Some(&l) = fits[i].iter().filter(|&&l| room(l)).min_by_key(|&&l| (out[l].len(), l)) else {
            let names: Vec<String> = fits[i].iter().map(|&l| format!("{} (max {})", show(leaves[l].path()), leaves[l].max.unwrap_or(0))).collect();
            return Err(PlanError::Invalid(format!("robot {} fits only teams that are full: {}", robots[i].id, names.join(", "))));
        };
        out[l].push(i);
    }
    for o in &mut out {
        o.sort_unstable();
    }
    Ok(out)
}

/// A maximum flow of the robots not `placed` to the leaves they `fit`, at most `wants[l]` to
/// leaf `l`: (robot, leaf) pairs, and how many.
fn min_flow(fits: &[Vec<usize>], wants: &[usize], placed: &[bool]) -> (Vec<(usize, usize)>, usize) {
    // Vertices: 0 source, 1 sink, 2.. robots, then leaves.
    let (n, source, sink) = (fits.len(), 0usize, 1usize);
    let vertices: Vec<usize> = (0..2 + n + wants.len()).collect();
    let mut edges = Vec::new();
    for (i, f) in fits.iter().enumerate().filter(|(i, _)| !placed[*i]) {
        edges.push(((source, 2 + i), 1i64));
        edges.extend(f.iter().filter(|&&l| wants[l] > 0).map(|&l| ((2 + i, 2 + n + l), 1i64)));
    }
    edges.extend(wants.iter().enumerate().filter(|(_, w)| **w > 0).map(|(l, w)| ((2 + n + l, sink), *w as i64)));
    let (flows, total, _) = edmonds_karp_sparse(&vertices, &source, &sink, edges);
    let pairs = flows
        .into_iter()
        .filter(|((from, to), f)| *f > 0 && *from >= 2 && *from < 2 + n && *to >= 2 + n)
        .map(|((from, to), _)| (from - 2, to - 2 - n))
        .collect();
    (pairs, total as usize)
}

/// Why the teams' minimums cannot be met, in words.
fn short(r: &Recipe, leaves: &[Leaf], fits: &[Vec<usize>], robots: usize, needed: usize, total: usize) -> PlanError {
    let eligible = |l: usize| fits.iter().filter(|f| f.contains(&l)).count();
    if let Some(l) = (0..leaves.len()).find(|&l| eligible(l) < leaves[l].min) {
        let leaf = &leaves[l];
        return PlanError::Invalid(format!(
            "team {} needs at least {} members ({}); of these {robots} robots only {} fit it",
            show(leaf.path()),
            leaf.min,
            leaf.wants(),
            eligible(l)
        ));
    }
    let mins: Vec<String> = leaves.iter().filter(|l| l.min > 0).map(|l| format!("{} {}", show(l.path()), l.min)).collect();
    PlanError::Invalid(format!(
        "the teams' minimums ({}) of recipe {} need {needed} robots that fit them; these {robots} robots fill at most {total}",
        mins.join(", "),
        r.name
    ))
}

fn show(path: &str) -> String {
    if path.is_empty() {
        "the mission".into()
    } else {
        path.to_string()
    }
}

#[cfg(test)]
#[path = "teams_tests.rs"]
mod tests;
