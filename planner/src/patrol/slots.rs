//! Where the robots start: slots every `L / n` along the route, their common offset and each
//! robot's slot chosen by a bottleneck assignment of travel times, within each robot's reach.

use crate::assign::{self, Costs};
use crate::error::PlanError;
use crate::geom::Point;
use crate::onmap::Approach;
use crate::plan::BEYOND_REACH_S;
use crate::polyline::Polyline;
use mrmm_proto::plan::RobotSpec;

/// Candidate slot offsets tried at most. Each costs a bottleneck assignment of the team to the
/// slots (O(n³); on a map n² route lookups too), and every offset of the team is within one slot
/// spacing `L/n` of another: trying each robot's own made planning O(n⁴) — 20 s for 225 robots,
/// past the planner's timeout — for a worst approach time better by less than `L/(n·v)`.
const MAX_OFFSETS: usize = 16;

/// What the slots are for: their spacing along the route, and the leg a robot drives from its
/// slot to the round's first sync point (with the way to its slot, what its reach must cover).
#[derive(Debug, Clone, Copy)]
pub(super) struct Slots {
    pub(super) spacing: f64,
    pub(super) leg: f64,
}

/// The robots placed on their slots.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Placed {
    /// Arc offset of slot 0.
    pub(super) offset: f64,
    /// Each robot's slot.
    pub(super) slot: Vec<usize>,
    /// Time until the last robot within reach of its slot is there, s.
    pub(super) formation_time: f64,
    /// The robots given a slot beyond their reach (indices).
    pub(super) short: Vec<usize>,
}

/// The slot offset along the route and the robots' slots: the bottleneck assignment of travel
/// times over candidate offsets (0, and each robot's own projection, or a spread of
/// [`MAX_OFFSETS`] of them), the smallest worst time first, then the smallest total. A slot
/// beyond a robot's reach costs [`BEYOND_REACH_S`] more.
pub(super) fn slots(robots: &[RobotSpec], approach: &Approach, path: &Polyline, s: Slots) -> Result<Placed, PlanError> {
    slots_among(robots, approach, path, s, MAX_OFFSETS)
}

/// [`slots`], trying at most `max_offsets` (≥ 2) candidate offsets.
fn slots_among(robots: &[RobotSpec], approach: &Approach, path: &Polyline, s: Slots, max_offsets: usize) -> Result<Placed, PlanError> {
    let n = robots.len();
    let here = |r: &RobotSpec| Point::new(r.x, r.y);
    let own: Vec<f64> = robots.iter().map(|r| path.project(here(r)) % s.spacing).collect();
    let candidates = offsets(own, max_offsets);
    let rows = |offset: f64| -> Vec<Vec<f64>> {
        robots
            .iter()
            .enumerate()
            .map(|(i, r)| {
                (0..n)
                    .map(|k| {
                        let d = approach.cost(i, here(r), path, offset + k as f64 * s.spacing).0;
                        let beyond = r.reach_m.is_some_and(|m| d + s.leg > m);
                        d / r.speed + if beyond { BEYOND_REACH_S } else { 0.0 }
                    })
                    .collect()
            })
            .collect()
    };
    // The smallest worst time of each candidate, then the assignment (least total among the
    // worst's) only for the candidates that tie on it: one assignment problem, not one each.
    let worst: Vec<f64> = candidates.iter().map(|&o| Costs::from_rows(&rows(o)).map(|c| assign::bottleneck_value(&c))).collect::<Result<_, _>>()?;
    let least = worst.iter().copied().fold(f64::INFINITY, f64::min);
    let mut best: Option<(f64, Vec<Vec<f64>>, assign::Assignment)> = None;
    for (&offset, _) in candidates.iter().zip(&worst).filter(|(_, &w)| w <= least + 1e-9) {
        let r = rows(offset);
        let a = assign::bottleneck(&Costs::from_rows(&r)?);
        if best.as_ref().is_none_or(|(_, _, b)| a.total < b.total - 1e-9) {
            best = Some((offset, r, a));
        }
    }
    let (offset, rows, a) = best.ok_or_else(|| PlanError::Invalid("no slot offset".into()))?;
    if !a.max.is_finite() {
        let r = robots.iter().enumerate().find(|(i, r)| !approach.cost(*i, here(r), path, offset).0.is_finite()).map(|(_, r)| r.id.clone()).unwrap_or_default();
        return Err(PlanError::Invalid(format!("robot {r} cannot reach the patrol's route on the map")));
    }
    let times: Vec<f64> = a.slot.iter().enumerate().map(|(i, &k)| rows[i][k]).collect();
    let short = (0..n).filter(|&i| times[i] >= BEYOND_REACH_S).collect();
    let formation_time = times.iter().copied().filter(|&t| t < BEYOND_REACH_S).fold(0.0, f64::max);
    Ok(Placed { offset, slot: a.slot, formation_time, short })
}

/// The offsets to try: 0 and the robots' own, or 0 and a spread of `max` − 1 (≥ 1) of them over
/// their sorted order (evenly through [0, spacing) as the robots are).
fn offsets(mut own: Vec<f64>, max: usize) -> Vec<f64> {
    if own.len() + 1 > max {
        own.sort_by(f64::total_cmp);
        let step = own.len() as f64 / (max - 1) as f64;
        own = (0..max - 1).map(|k| own[(k as f64 * step) as usize]).collect();
    }
    std::iter::once(0.0).chain(own).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patrol::tests::{robot, square};

    #[test]
    fn a_spread_of_offsets_is_within_one_slot_spacing_of_trying_every_robots() {
        // 60 robots scattered around the square: every robot's offset tried against a spread of
        // 16. Shifting the slots by δ along the tour moves each by at most δ, so the worst
        // approach time can only be worse by the largest gap between two tried offsets (< L/n).
        let robots: Vec<RobotSpec> = (0..60)
            .map(|i| {
                let a = f64::from(i) * 2.399_963;
                robot(&format!("r{i}"), 20.0 + (10.0 + f64::from(i % 7) * 4.0) * a.cos(), 20.0 + (10.0 + f64::from(i % 5) * 5.0) * a.sin(), 1.0)
            })
            .collect();
        let path = Polyline::closed(&square());
        let spacing = path.length / robots.len() as f64;
        let approach = Approach::Plane;
        let s = Slots { spacing, leg: 0.0 };
        let all = slots_among(&robots, &approach, &path, s, usize::MAX).expect("all").formation_time;
        let spread = slots(&robots, &approach, &path, s).expect("spread").formation_time;
        assert!(spread >= all - 1e-9, "trying every offset is never worse");
        assert!(spread <= all + spacing + 1e-9, "spread {spread} against every offset {all} (spacing {spacing})");
        // Not all 61 candidates were needed to get close: within a fifth of a slot here.
        assert!(spread - all < spacing / 5.0, "spread {spread} against {all}");
    }

    #[test]
    fn the_offsets_tried_spread_over_the_robots() {
        // 100 robots' offsets through [0, 1): the 16 tried leave no gap wider than 2/15.
        let own: Vec<f64> = (0..100).map(|i| f64::from((i * 37) % 100) / 100.0).collect();
        let mut tried = offsets(own.clone(), 16);
        assert_eq!((tried.len(), tried[0]), (16, 0.0));
        tried.sort_by(f64::total_cmp);
        let widest = tried.windows(2).map(|w| w[1] - w[0]).chain([1.0 - tried[15]]).fold(0.0, f64::max);
        assert!(widest <= 2.0 / 15.0, "a gap of {widest} between offsets tried: {tried:?}");
        assert!(tried[1..].iter().all(|o| own.contains(o)), "only the robots' own");
        // A small team: every robot's own, and 0.
        assert_eq!(offsets(vec![0.5, 0.25], 16), [0.0, 0.5, 0.25]);
    }
}
