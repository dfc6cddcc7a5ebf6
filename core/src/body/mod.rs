//! Robot bodies: the simulated one here (unicycle kinematics with speed and turn-rate limits), a
//! ROS 2 robot's ([`ros`]: mrmm's own controller over `cmd_vel`, or Nav2 goals, [`nav_goals`]),
//! a VDA 5050 vehicle's ([`vda`]: orders), and the one interface the robot drives any of them
//! through ([`drive`]).
//!
//! The simulated body integrates in simulated time; the caller scales wall time by the robot's
//! `time_scale` before calling [`Body::step`].

pub mod battery;
pub mod drive;
pub mod nav_goals;
pub mod ros;
pub mod vda;

use nalgebra::{Rotation2, Vector2};

use self::battery::Battery;
use mrmm_planner::corner::Blend;
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
    /// The arc through the goal towards the point after it, when the plan drives on from there
    /// ([`Body::navigate_through`]).
    corner: Option<Corner>,
    /// Its battery, if it has one: empty, the body does not move.
    battery: Option<Battery>,
}

/// Where a plan drives on to from a goal without stopping there, and how fast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Onward {
    pub x: f64,
    pub y: f64,
    /// Speed cap of the leg from the goal on (None: the robot's maximum).
    pub speed: Option<f64>,
}

/// A corner the body rounds instead of stopping at it.
#[derive(Debug, Clone, Copy)]
struct Corner {
    blend: Blend,
    /// The heading of the leg after the corner.
    out: f64,
    /// The room the arc has on the legs before and after the corner, metres: all that is left
    /// of the leg the body is on (a corner before it took its part already), half of the next.
    legs: (f64, f64),
    /// The speeds of the legs before and after the corner, m/s.
    speeds: (f64, f64),
    /// Set once the body is on the arc: the heading change left to turn.
    left: Option<f64>,
}

/// The body rounds a corner only if it comes to the arc's start heading along its leg within
/// this angle, radians (otherwise it stops at the corner and turns there).
const BLEND_ALIGN: f64 = 0.05;

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
            corner: None,
            battery: None,
        }
    }

    /// The body with a battery.
    pub fn with_battery(mut self, battery: Battery) -> Self {
        self.battery = Some(battery);
        self
    }

    pub fn battery(&self) -> Option<&Battery> {
        self.battery.as_ref()
    }

    pub fn battery_mut(&mut self) -> Option<&mut Battery> {
        self.battery.as_mut()
    }

    pub fn limits(&self) -> Limits {
        self.limits
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

    /// Neither driving to a goal nor turning to face a point.
    pub fn idle(&self) -> bool {
        self.goal.is_none() && self.facing.is_none()
    }

    /// Start driving to (x, y). Non-finite goals are ignored by the caller's validation.
    pub fn navigate_to(&mut self, x: f64, y: f64) {
        self.navigate_capped(x, y, None);
    }

    /// Drive to (x, y) no faster than `speed` (m/s).
    pub fn navigate_capped(&mut self, x: f64, y: f64, speed: Option<f64>) {
        self.goal = Some(Vector2::new(x, y));
        if let Some(b) = &mut self.battery {
            b.set_charging(false);
        }
        self.cap = speed.filter(|s| s.is_finite() && *s > 0.0);
        self.facing = None;
        self.corner = None;
    }

    /// Drive to (x, y) no faster than `speed` and, when `then` is given (the plan drives on
    /// from there), round the corner on an arc ([`Blend`]) instead of stopping and turning at
    /// it: the goal counts as reached at the arc's end, facing the next point.
    pub fn navigate_through(&mut self, x: f64, y: f64, then: Option<Onward>, speed: Option<f64>) {
        self.navigate_capped(x, y, speed);
        let Some(then) = then else { return };
        let (goal, next) = (Vector2::new(x, y), Vector2::new(then.x, then.y));
        let (leg_in, leg_out) = (goal - self.pos, next - goal);
        let a_in = leg_in.y.atan2(leg_in.x);
        let out = leg_out.y.atan2(leg_out.x);
        let angle = wrap_angle(out - a_in).abs();
        let legs = (leg_in.norm(), leg_out.norm() / 2.0);
        let speeds = (self.top_speed(), self.capped(then.speed.filter(|s| s.is_finite() && *s > 0.0)));
        self.corner = Blend::through(angle, legs.0, legs.1, speeds, self.limits.max_turn_rate).map(|blend| Corner { blend, out, legs, speeds, left: None });
    }

    fn top_speed(&self) -> f64 {
        self.capped(self.cap)
    }

    fn capped(&self, cap: Option<f64>) -> f64 {
        cap.map_or(self.limits.max_speed, |c| c.min(self.limits.max_speed))
    }

    /// Stop now.
    pub fn hold(&mut self) {
        self.goal = None;
        self.facing = None;
        self.corner = None;
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
    /// during this step (the goal is then cleared). With a battery, the step drains it by the
    /// time, the distance and the turn; a body whose battery is empty, or charging (plugged in),
    /// stands where it is, its goal kept (a new goal unplugs it).
    pub fn step(&mut self, dt: f64) -> bool {
        if self.battery.as_ref().is_some_and(|b| b.empty() || b.charging()) {
            self.velocity = Velocity::default();
            if let Some(b) = &mut self.battery {
                b.pass(dt, 0.0, 0.0);
            }
            return false;
        }
        let (pos, heading) = (self.pos, self.heading);
        let arrived = self.move_for(dt);
        if let Some(b) = &mut self.battery {
            b.pass(dt, (self.pos - pos).norm(), wrap_angle(self.heading - heading));
        }
        arrived
    }

    /// [`Body::step`] without the battery.
    fn move_for(&mut self, dt: f64) -> bool {
        let Some(goal) = self.goal else {
            self.turn_to_face(dt);
            return false;
        };
        if dt <= 0.0 {
            return false;
        }
        let dt = match self.approach_corner(goal, dt) {
            Approach::Arc(dt) => return self.round_corner(dt),
            Approach::Drive(dt) => dt,
        };
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
        let max = self.top_speed();
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

/// What a step does about a corner ahead.
enum Approach {
    /// Drive to the goal as usual for this many seconds.
    Drive(f64),
    /// Go on (or start) round the corner's arc for this many seconds.
    Arc(f64),
}

impl Body {
    /// With a corner to round ahead: while the body is short of the arc's start, or not lined
    /// up with its leg, it drives on as usual (a body off its leg at the arc's start gives the
    /// arc up and stops at the corner); once it reaches the start lined up, the rest of the step
    /// goes on the arc.
    fn approach_corner(&mut self, goal: Vector2<f64>, dt: f64) -> Approach {
        let Some(c) = self.corner else { return Approach::Drive(dt) };
        if c.left.is_some() {
            return Approach::Arc(dt);
        }
        let to_goal = goal - self.pos;
        if to_goal.norm() <= ARRIVAL_TOLERANCE {
            self.corner = None;
            return Approach::Drive(dt);
        }
        let short = to_goal.norm() - c.blend.tangent;
        let speed = self.top_speed();
        if short > speed * dt {
            return Approach::Drive(dt);
        }
        let err = wrap_angle(to_goal.y.atan2(to_goal.x) - self.heading);
        if err.abs() > BLEND_ALIGN {
            self.corner = None;
            return Approach::Drive(dt);
        }
        // The arc for the heading change left from here (the body may be a little off its leg).
        let heading = to_goal.y.atan2(to_goal.x);
        let left = wrap_angle(c.out - heading);
        let Some(blend) = Blend::through(left.abs(), c.legs.0, c.legs.1, c.speeds, self.limits.max_turn_rate) else {
            self.corner = None;
            return Approach::Drive(dt);
        };
        let ahead = (to_goal.norm() - blend.tangent).max(0.0);
        if ahead > speed * dt {
            self.corner = Some(Corner { blend, ..c });
            return Approach::Drive(dt);
        }
        self.pos += to_goal.normalize() * ahead;
        self.heading = heading;
        self.corner = Some(Corner { blend, left: Some(left), ..c });
        Approach::Arc(dt - ahead / speed)
    }

    /// Drives `dt` seconds along the corner's arc (its first half at the leg before's speed,
    /// its second at the next leg's); true when its end is reached (the goal, then, counts as
    /// reached).
    fn round_corner(&mut self, dt: f64) -> bool {
        let Some(c @ Corner { left: Some(mut left), .. }) = self.corner else { return false };
        let (mut time, mut turned) = (dt.max(0.0), 0.0);
        while time > 0.0 && left.abs() > 1e-9 {
            let rate = c.blend.turn_rate(left.abs());
            // Up to the arc's middle, where the speed changes, or its end.
            let piece = if left.abs() > c.blend.angle / 2.0 + 1e-12 { left.abs() - c.blend.angle / 2.0 } else { left.abs() };
            let turn = piece.min(rate * time).copysign(left);
            // Exact on a circle: the chord of the turned angle, along the mean heading.
            let chord = 2.0 * c.blend.radius * (turn.abs() / 2.0).sin();
            self.pos += Rotation2::new(self.heading + turn / 2.0) * Vector2::x() * chord;
            self.heading = wrap_angle(self.heading + turn);
            time -= turn.abs() / rate;
            left -= turn;
            turned += turn;
        }
        let used = dt - time.max(0.0);
        self.velocity = if used > 0.0 { Velocity { v: c.blend.radius * turned.abs() / used, omega: turned / used } } else { Velocity::default() };
        if left.abs() <= 1e-9 {
            self.hold();
            return true;
        }
        self.corner = Some(Corner { left: Some(left), ..c });
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

    /// Driving through a right-angle corner (the plan goes on from it), the body rounds it on the
    /// arc the planner times: it never comes further than the cut inside the corner, it is
    /// never off the route by more, and it takes the arc's time, quicker than stopping to turn.
    #[test]
    fn a_corner_driven_through_is_rounded_within_the_cut() {
        use mrmm_planner::corner::CORNER_CUT;
        let lim = Limits { max_speed: 1.0, max_turn_rate: 3.0 };
        let drive = |through: bool| {
            let mut b = Body::new(Pose::default(), lim);
            let then = through.then_some(Onward { x: 10.0, y: 10.0, speed: None });
            b.navigate_through(10.0, 0.0, then, None);
            let (mut t, mut off, mut legs) = (0.0, 0.0f64, 0);
            while legs < 2 && t < 100.0 {
                if b.step(0.01) {
                    legs += 1;
                    b.navigate_to(10.0, 10.0);
                }
                t += 0.01;
                let p = b.pose();
                // Distance from the route: the nearer of its two legs.
                let d1 = if p.x <= 10.0 { p.y.abs() } else { (p.x - 10.0).hypot(p.y) };
                let d2 = if p.y >= 0.0 { (p.x - 10.0).abs() } else { (p.x - 10.0).hypot(p.y) };
                off = off.max(d1.min(d2));
            }
            (t, off, b.pose())
        };
        let (rounded, off, end) = drive(true);
        let (stopping, _, _) = drive(false);
        assert!(off <= CORNER_CUT + 1e-6, "{off} m off the route");
        assert!(off > CORNER_CUT / 2.0, "it did cut the corner: {off}");
        let b = Blend::through(std::f64::consts::FRAC_PI_2, 10.0, 5.0, (1.0, 1.0), 3.0).expect("rounded");
        let planned = 20.0 - 2.0 * b.tangent + b.seconds();
        assert!((rounded - planned).abs() < 0.05, "{rounded} s, planned {planned} s");
        assert!(rounded < stopping - 0.25, "rounded {rounded} s, stopping to turn {stopping} s");
        assert!((end.x - 10.0).abs() <= ARRIVAL_TOLERANCE && (end.y - 10.0).abs() <= ARRIVAL_TOLERANCE);
    }

    /// A U-turn cannot be rounded within the cut: the body stops at the point and turns there.
    #[test]
    fn a_u_turn_is_turned_on_the_spot() {
        let mut b = Body::new(Pose::default(), Limits { max_speed: 1.0, max_turn_rate: 3.0 });
        b.navigate_through(5.0, 0.0, Some(Onward { x: 0.0, y: 0.0, speed: None }), None);
        let steps = run_until_arrival(&mut b, 0.01, 10_000).expect("arrives");
        assert!((steps as f64 * 0.01 - 5.0).abs() < 0.05);
        assert!((b.pose().x - 5.0).abs() <= ARRIVAL_TOLERANCE && b.pose().theta.abs() < 1e-9, "at the point, not turned yet");
    }

    /// An empty battery stops the body short of its goal; charged, it drives on to it.
    #[test]
    fn an_empty_battery_stops_the_body_until_charged() {
        use battery::BatteryModel;
        // 5 s of driving at 1 m/s in a full charge.
        let mut b = Body::new(Pose::default(), LIM).with_battery(Battery::new(BatteryModel::lasting(5.0, 1.0), 1.0));
        b.navigate_to(10.0, 0.0);
        assert!(run_until_arrival(&mut b, 0.01, 2_000).is_none(), "it cannot get there");
        let stopped = b.pose();
        assert!((stopped.x - 5.0).abs() < 0.05, "{stopped:?}");
        assert!(b.battery().expect("battery").empty());
        assert_eq!(b.velocity(), Velocity::default());
        assert_eq!(b.goal(), Some((10.0, 0.0)), "the goal is kept");
        b.battery_mut().expect("battery").set_charging(true);
        for _ in 0..300 {
            b.step(0.01);
        }
        assert_eq!(b.pose(), stopped, "plugged in, it does not drive");
        assert_eq!(b.battery().expect("battery").charge(), 1.0);
        b.battery_mut().expect("battery").set_charging(false);
        assert!(run_until_arrival(&mut b, 0.01, 2_000).is_some(), "charged, it gets there");
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
