//! The simulated robot body: unicycle kinematics with speed and turn-rate limits.
//!
//! The body integrates in simulated time; the caller scales wall time by the robot's
//! `time_scale` before calling [`Body::step`].

use nalgebra::{Rotation2, Vector2};

use mrmm_proto::{Pose, Velocity};

/// Physical limits of a robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Maximum linear speed, m/s.
    pub max_speed: f64,
    /// Maximum turn rate, rad/s.
    pub max_turn_rate: f64,
}

/// Distance under which a navigation goal counts as reached, metres.
pub const ARRIVAL_TOLERANCE: f64 = 0.05;
/// Near the goal, the body drives only when facing it within this angle, radians.
const NEAR_ALIGN: f64 = 0.2;
/// Further away, it turns in place while its heading is off by more than this, radians, so it
/// follows a route's straight segments instead of sweeping wide arcs at the corners (a route
/// on a map keeps a robot radius from the walls; an arc would not).
const FAR_ALIGN: f64 = 0.5;

/// A unicycle robot: position, heading, and the goal it is driving to.
#[derive(Debug, Clone)]
pub struct Body {
    pos: Vector2<f64>,
    heading: f64,
    velocity: Velocity,
    limits: Limits,
    goal: Option<Vector2<f64>>,
    /// Speed cap of the current goal (a plan's team speed), below the robot's maximum.
    cap: Option<f64>,
    /// With no goal: a point to turn on the spot to face (the next one of the plan, while the
    /// robot waits at a barrier).
    facing: Option<Vector2<f64>>,
}

impl Body {
    pub fn new(start: Pose, limits: Limits) -> Self {
        Body {
            pos: Vector2::new(start.x, start.y),
            heading: wrap_angle(start.theta),
            velocity: Velocity::default(),
            limits,
            goal: None,
            cap: None,
            facing: None,
        }
    }

    pub fn pose(&self) -> Pose {
        Pose { x: self.pos.x, y: self.pos.y, theta: self.heading }
    }

    pub fn velocity(&self) -> Velocity {
        self.velocity
    }

    pub fn goal(&self) -> Option<(f64, f64)> {
        self.goal.map(|g| (g.x, g.y))
    }

    /// Start driving to (x, y). Non-finite goals are ignored by the caller's validation.
    pub fn navigate_to(&mut self, x: f64, y: f64) {
        self.navigate_capped(x, y, None);
    }

    /// Drive to (x, y) no faster than `speed` (m/s).
    pub fn navigate_capped(&mut self, x: f64, y: f64, speed: Option<f64>) {
        self.goal = Some(Vector2::new(x, y));
        self.cap = speed.filter(|s| s.is_finite() && *s > 0.0);
        self.facing = None;
    }

    /// Stop now.
    pub fn hold(&mut self) {
        self.goal = None;
        self.facing = None;
        self.velocity = Velocity::default();
    }

    /// Stop, and turn on the spot to face (x, y): a robot waiting at a barrier faces where it
    /// goes next, so that it drives off when the barrier releases (its team is spaced by time
    /// with its turns counted). A goal given later replaces it.
    pub fn face(&mut self, x: f64, y: f64) {
        self.hold();
        self.facing = Some(Vector2::new(x, y));
    }

    /// Turns towards the point to face, if any, for `dt` seconds.
    fn turn_to_face(&mut self, dt: f64) {
        self.velocity = Velocity::default();
        let Some(to) = self.facing else { return };
        let d = to - self.pos;
        let err = wrap_angle(d.y.atan2(d.x) - self.heading);
        if d.norm() <= ARRIVAL_TOLERANCE || err.abs() < 1e-3 || dt <= 0.0 {
            self.facing = None;
            return;
        }
        let turn = err.clamp(-self.limits.max_turn_rate * dt, self.limits.max_turn_rate * dt);
        self.heading = wrap_angle(self.heading + turn);
        self.velocity = Velocity { v: 0.0, omega: turn / dt };
    }

    /// Advances the body by `dt` seconds of simulated time. Returns true when it reached its goal
    /// during this step (the goal is then cleared).
    pub fn step(&mut self, dt: f64) -> bool {
        let Some(goal) = self.goal else {
            self.turn_to_face(dt);
            return false;
        };
        if dt <= 0.0 {
            return false;
        }
        let to_goal = goal - self.pos;
        let dist = to_goal.norm();
        if dist <= ARRIVAL_TOLERANCE {
            self.hold();
            return true;
        }
        let desired = to_goal.y.atan2(to_goal.x);
        let err = wrap_angle(desired - self.heading);
        let max_turn = self.limits.max_turn_rate * dt;
        let turn = err.clamp(-max_turn, max_turn);
        self.heading = wrap_angle(self.heading + turn);
        let left = (err - turn).abs();
        let max = self.cap.map_or(self.limits.max_speed, |c| c.min(self.limits.max_speed));
        // Near the goal (within two turning radii) a unicycle that drives while misaligned can
        // orbit the goal for ever: turn in place until facing it, then close in. Further away,
        // slow down in proportion to the heading error, to a stop at FAR_ALIGN.
        let turning_radius = max / self.limits.max_turn_rate;
        let align = if dist < 2.0 * turning_radius {
            if left > NEAR_ALIGN {
                0.0
            } else {
                left.cos()
            }
        } else {
            (1.0 - left / FAR_ALIGN).clamp(0.0, 1.0)
        };
        let speed = max * align;
        let advance = (speed * dt).min(dist);
        let dir = Rotation2::new(self.heading) * Vector2::x();
        self.pos += dir * advance;
        self.velocity = Velocity { v: advance / dt, omega: turn / dt };
        if (goal - self.pos).norm() <= ARRIVAL_TOLERANCE {
            self.hold();
            return true;
        }
        false
    }
}

/// Wraps an angle to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = std::f64::consts::TAU;
    let mut r = a.rem_euclid(two_pi);
    if r > std::f64::consts::PI {
        r -= two_pi;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIM: Limits = Limits { max_speed: 1.0, max_turn_rate: 2.0 };

    fn run_until_arrival(b: &mut Body, dt: f64, max_steps: usize) -> Option<usize> {
        (1..=max_steps).find(|_| b.step(dt))
    }

    #[test]
    fn straight_line_takes_distance_over_speed() {
        let mut b = Body::new(Pose::default(), LIM);
        b.navigate_to(10.0, 0.0);
        let steps = run_until_arrival(&mut b, 0.01, 10_000).expect("arrives");
        let t = steps as f64 * 0.01;
        assert!((t - 10.0).abs() < 0.1, "t = {t}");
        assert!((b.pose().x - 10.0).abs() <= ARRIVAL_TOLERANCE);
        assert_eq!(b.velocity(), Velocity::default());
        assert!(b.goal().is_none());
    }

    #[test]
    fn turns_first_when_goal_is_behind() {
        let mut b = Body::new(Pose { x: 0.0, y: 0.0, theta: 0.0 }, LIM);
        b.navigate_to(-5.0, 0.0);
        b.step(0.1);
        // Facing away: turns at the limit and barely moves.
        assert!((b.pose().theta.abs() - 0.2).abs() < 1e-9);
        assert!(b.pose().x.abs() < 1e-9);
        let steps = run_until_arrival(&mut b, 0.01, 100_000).expect("arrives");
        let t = steps as f64 * 0.01;
        // Half a turn at 2 rad/s (~1.57 s) plus 5 m at 1 m/s, with some slack for blending.
        assert!(t > 5.0 && t < 7.5, "t = {t}");
    }

    #[test]
    fn faces_a_point_turning_on_the_spot() {
        let mut b = Body::new(Pose::default(), LIM);
        b.face(0.0, 5.0);
        // A quarter turn at 2 rad/s: ~0.79 s, without moving; then it holds.
        for _ in 0..100 {
            assert!(!b.step(0.01), "facing is not a goal reached");
        }
        assert!((b.pose().theta - std::f64::consts::FRAC_PI_2).abs() < 1e-3, "{:?}", b.pose());
        assert!(b.pose().x.abs() < 1e-12 && b.pose().y.abs() < 1e-12);
        assert_eq!(b.velocity(), Velocity::default());
        // A goal replaces it: facing the far side, then driving off.
        b.face(0.0, -5.0);
        b.navigate_to(5.0, 0.0);
        b.step(0.01);
        assert!(b.goal().is_some());
    }

    #[test]
    fn never_exceeds_limits() {
        let mut b = Body::new(Pose { x: 1.0, y: 2.0, theta: 2.0 }, LIM);
        b.navigate_to(-3.0, 7.0);
        for _ in 0..2000 {
            let before = b.pose();
            b.step(0.05);
            let after = b.pose();
            let d = ((after.x - before.x).powi(2) + (after.y - before.y).powi(2)).sqrt();
            assert!(d <= 1.0 * 0.05 + 1e-9);
            assert!(wrap_angle(after.theta - before.theta).abs() <= 2.0 * 0.05 + 1e-9);
        }
        assert!(b.goal().is_none(), "arrived");
        assert!(((b.pose().x + 3.0).powi(2) + (b.pose().y - 7.0).powi(2)).sqrt() <= ARRIVAL_TOLERANCE);
    }

    #[test]
    fn speed_cap_slows_down() {
        let mut b = Body::new(Pose::default(), LIM);
        b.navigate_capped(5.0, 0.0, Some(0.5));
        let steps = run_until_arrival(&mut b, 0.01, 10_000).expect("arrives");
        assert!((steps as f64 * 0.01 - 10.0).abs() < 0.2);
    }

    #[test]
    fn reaches_near_goals_at_coarse_time_steps_without_orbiting() {
        // A 0.2 s step (time scale 10 at 50 Hz): goals closer than the turning radius, at every
        // bearing, are reached.
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            for d in [0.1, 0.3, 0.6, 1.5] {
                let mut b = Body::new(Pose { x: 0.0, y: 0.0, theta: 0.0 }, LIM);
                b.navigate_capped(d * a.cos(), d * a.sin(), Some(1.0));
                assert!(run_until_arrival(&mut b, 0.2, 200).is_some(), "bearing {a:.2}, distance {d}");
            }
        }
    }

    /// Driving a route's right-angle corner, the body stays close to the two segments.
    #[test]
    fn a_corner_is_turned_on_the_spot_not_swept() {
        let mut b = Body::new(Pose { x: 0.0, y: 0.0, theta: 0.0 }, Limits { max_speed: 1.0, max_turn_rate: 1.5 });
        b.navigate_to(10.0, 0.0);
        run_until_arrival(&mut b, 0.05, 10_000).expect("first leg");
        b.navigate_to(10.0, 10.0);
        let mut worst: f64 = 0.0;
        for _ in 0..10_000 {
            let arrived = b.step(0.05);
            let p = b.pose();
            worst = worst.max((p.x - 10.0).abs());
            if arrived {
                break;
            }
        }
        assert!(worst < 0.1, "strayed {worst} m off the second leg");
    }

    #[test]
    fn hold_stops() {
        let mut b = Body::new(Pose::default(), LIM);
        b.navigate_to(3.0, 3.0);
        b.step(0.1);
        b.hold();
        let p = b.pose();
        b.step(1.0);
        assert_eq!(b.pose(), p);
    }

    #[test]
    fn wrap_angle_range() {
        for k in -20..20 {
            let a = wrap_angle(k as f64 * 0.7);
            assert!(a > -std::f64::consts::PI - 1e-12 && a <= std::f64::consts::PI + 1e-12);
        }
        assert!((wrap_angle(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-9);
    }
}
