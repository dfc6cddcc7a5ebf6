//! How a robot drives through a corner of its route without stopping: an arc that cuts the
//! corner by at most [`CORNER_CUT`], the model shared by the simulated body (which drives it) and
//! the patrol planner (which times the route with it).
//!
//! A unicycle that turns at most `ω` rad/s can round a corner whose heading changes by `φ` on an
//! arc of radius `R` at speed `min(v, ω·R)`. The arc starts and ends `R·tan(φ/2)` from the corner
//! on its two legs and passes `R·(1/cos(φ/2) − 1)` inside it: the radius is the largest that
//! keeps that cut within [`CORNER_CUT`] and the arc within half of each leg (so that two
//! corners' arcs never overlap). Against turning on the spot at the corner (`2·R·tan(φ/2)/v +
//! φ/ω`), the arc takes `max(R·φ/v, φ/ω)`, never more.

/// How far inside a corner a robot passing through it may come, metres. A route on a map keeps
/// the robot's radius from the walls at its corners; the arc uses this much of that margin.
pub const CORNER_CUT: f64 = 0.1;
/// Below this radius (a turn close to a U-turn, or a very short leg) the robot stops at the
/// corner and turns on the spot instead, metres.
const MIN_RADIUS: f64 = 0.02;
/// Heading changes smaller than this are not rounded (the robot drives to the corner and on,
/// turning by so little there), radians.
const STRAIGHT: f64 = 1e-3;

/// The arc a robot drives through one corner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blend {
    /// Heading change, radians in (0, π).
    pub angle: f64,
    /// The arc's radius, metres.
    pub radius: f64,
    /// Distance from the corner, along each leg, of the arc's ends, metres.
    pub tangent: f64,
    /// Speed on the arc's first half and on its second half, m/s.
    pub speed: (f64, f64),
}

impl Blend {
    /// The arc for a corner whose heading changes by `angle` (radians, [0, π]) with `room_in`
    /// metres of the leg before it and `room_out` of the leg after it to start and end in, for a
    /// robot driving them at `speed` m/s (the leg before, the leg after) and turning at most
    /// `turn_rate` rad/s; None where the robot stops and turns on the spot (no turn, a turn too
    /// sharp for the cut, no room, or limits that are not finite and positive).
    pub fn through(angle: f64, room_in: f64, room_out: f64, speed: (f64, f64), turn_rate: f64) -> Option<Blend> {
        let valid = |v: f64| v.is_finite() && v > 0.0;
        if !(valid(speed.0) && valid(speed.1) && valid(turn_rate) && valid(room_in) && valid(room_out) && angle.is_finite()) {
            return None;
        }
        if angle <= STRAIGHT || angle >= std::f64::consts::PI - STRAIGHT {
            return None;
        }
        let half = angle / 2.0;
        let cut_per_radius = 1.0 / half.cos() - 1.0;
        let radius = (CORNER_CUT / cut_per_radius).min(room_in.min(room_out) / half.tan());
        // (Not finite, or too small: a NaN compares false.)
        if radius.is_nan() || radius < MIN_RADIUS {
            return None;
        }
        let most = turn_rate * radius;
        Some(Blend { angle, radius, tangent: radius * half.tan(), speed: (speed.0.min(most), speed.1.min(most)) })
    }

    /// Seconds on the arc.
    pub fn seconds(&self) -> f64 {
        self.radius * self.angle / 2.0 * (1.0 / self.speed.0 + 1.0 / self.speed.1)
    }

    /// The arc's turn rate, rad/s, with `left` radians of it still to turn (positive: the
    /// magnitude; the side is the corner's).
    pub fn turn_rate(&self, left: f64) -> f64 {
        let speed = if left > self.angle / 2.0 { self.speed.0 } else { self.speed.1 };
        speed / self.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn a_right_angle_is_rounded_within_the_cut() {
        let b = Blend::through(FRAC_PI_2, 5.0, 5.0, (1.0, 1.0), 3.0).expect("blended");
        let cut = b.radius * (1.0 / (b.angle / 2.0).cos() - 1.0);
        assert!((cut - CORNER_CUT).abs() < 1e-12, "{cut}");
        assert!((b.tangent - b.radius).abs() < 1e-12, "tan 45° = 1");
        // R = 0.1 / (√2 − 1) ≈ 0.241 m < v/ω: the arc is driven at ω·R.
        assert!((b.speed.0 - 3.0 * b.radius).abs() < 1e-12 && b.speed.0 == b.speed.1);
        assert!((b.seconds() - FRAC_PI_2 / 3.0).abs() < 1e-12);
        // Never slower than stopping and turning on the spot there.
        let on_the_spot = 2.0 * b.tangent / 1.0 + FRAC_PI_2 / 3.0;
        assert!(b.seconds() < on_the_spot);
    }

    #[test]
    fn a_gentle_bend_keeps_full_speed_and_short_legs_bound_the_arc() {
        let b = Blend::through(0.2, 50.0, 50.0, (1.0, 1.0), 3.0).expect("blended");
        assert_eq!(b.speed, (1.0, 1.0));
        assert!(b.seconds() < 2.0 * b.tangent, "the arc is shorter than the corner's legs");
        // Each half of the arc at its leg's speed.
        let two = Blend::through(0.2, 50.0, 50.0, (1.0, 2.0), 3.0).expect("blended");
        assert!((two.seconds() - 0.75 * b.seconds()).abs() < 1e-9);
        assert_eq!((two.turn_rate(0.15), two.turn_rate(0.05)), (1.0 / two.radius, 2.0 / two.radius));
        let short = Blend::through(0.2, 0.5, 0.3, (1.0, 1.0), 3.0).expect("blended");
        assert!((short.tangent - 0.3).abs() < 1e-12, "the smaller room: {}", short.tangent);
    }

    #[test]
    fn u_turns_straight_lines_and_bad_limits_are_not_blended() {
        let v = (1.0, 1.0);
        assert_eq!(Blend::through(PI, 10.0, 10.0, v, 3.0), None);
        assert_eq!(Blend::through(0.0, 10.0, 10.0, v, 3.0), None);
        assert_eq!(Blend::through(3.1, 10.0, 10.0, v, 3.0), None, "R below the minimum");
        assert_eq!(Blend::through(1.0, 10.0, 10.0, (1.0, f64::NAN), 3.0), None);
        assert_eq!(Blend::through(1.0, 10.0, 0.0, v, 3.0), None);
        assert_eq!(Blend::through(1.0, 10.0, 10.0, v, f64::INFINITY), None);
    }
}
