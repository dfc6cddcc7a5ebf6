//! Reading a plan ahead of its current step: where the robot faces while it waits, and where it
//! drives on to from the point it is driving to.

use std::collections::BTreeMap;

use mrmm_proto::Step;

use crate::body::Onward;

/// The point the plan drives to next after step `pc` (through its loop and timed holds), if it
/// drives somewhere before it holds for good.
pub(super) fn next_point(steps: &[Step], pc: usize) -> Option<(f64, f64)> {
    let mut pc = pc + 1;
    for _ in 0..=steps.len() {
        match steps.get(pc)? {
            Step::Navigate { x, y, .. } => return Some((*x, *y)),
            Step::Hold { seconds: None } => return None,
            Step::Hold { seconds: Some(_) } => pc += 1,
            Step::Loop { to, .. } => pc = *to,
            Step::Stream | Step::Sync { .. } => pc += 1,
        }
    }
    None
}

/// The point the plan drives to right after step `pc`, without a barrier, a hold or its end in
/// between (through its loop, unless `loops`, the rounds done by each loop step, say that was its
/// last round): the corner at step `pc`'s point is driven through.
pub(super) fn onward(steps: &[Step], pc: usize, loops: &BTreeMap<usize, u32>) -> Option<Onward> {
    let mut pc = pc + 1;
    for _ in 0..=steps.len() {
        match steps.get(pc)? {
            Step::Navigate { x, y, speed } => return Some(Onward { x: *x, y: *y, speed: *speed }),
            Step::Loop { to, rounds } => {
                let count = loops.get(&pc).copied().unwrap_or(0);
                if rounds.is_some_and(|r| count.saturating_add(1) >= r) || *to >= pc {
                    return None;
                }
                pc = *to;
            }
            Step::Stream => pc += 1,
            Step::Hold { .. } | Step::Sync { .. } => return None,
        }
    }
    None
}
