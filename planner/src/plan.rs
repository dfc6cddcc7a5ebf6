//! Robot plans are the protocol's (`mrmm_proto::plan`: `Step`, `RobotPlan`, `RobotSpec`): the
//! planners take the robots and emit the plans as they travel. What the planners check of the
//! robots they are given is here.

use mrmm_proto::plan::RobotSpec;

/// Added to the time of a slot beyond a robot's reach (`RobotSpec::reach_m`): the bottleneck
/// assignment gives one only when there is no other way, and the robot given it is left out.
pub(crate) const BEYOND_REACH_S: f64 = 1e9;

/// Removes the items at positions `at` (of `v` as it is) from `v`: the robots a plan leaves out,
/// before it is made again for the others.
pub(crate) fn drop_at<T>(v: &mut Vec<T>, at: &[usize]) {
    let mut i = 0;
    v.retain(|_| {
        i += 1;
        !at.contains(&(i - 1))
    });
}

/// Rejects no robots, a robot at a non-finite or far position, a speed that is not positive, a
/// turn rate out of bounds, a reach that is not a distance, and one robot given twice.
pub(crate) fn check(robots: &[RobotSpec]) -> Result<(), crate::PlanError> {
    if robots.is_empty() {
        return Err(crate::PlanError::Invalid("no robots".into()));
    }
    for r in robots {
        crate::limits::coordinate(&format!("robot {} position", r.id), r.x, r.y)?;
        if !(r.speed.is_finite() && r.speed > 0.0) {
            return Err(crate::PlanError::Invalid(format!("robot {}: speed must be positive (got {})", r.id, r.speed)));
        }
        if let Some(m) = r.reach_m {
            if !(m.is_finite() && m >= 0.0) {
                return Err(crate::PlanError::Invalid(format!("robot {}: reach_m must be a distance of 0 or more (got {m})", r.id)));
            }
        }
        if let Some(w) = r.turn_rate {
            crate::limits::turn_rate(&format!("robot {} turn_rate", r.id), w)?;
        }
    }
    let mut ids: Vec<&str> = robots.iter().map(|r| r.id.as_str()).collect();
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        return Err(crate::PlanError::Invalid(format!("robot {} given twice", w[0])));
    }
    Ok(())
}
