//! A ROS 2 robot as the robot's body, without I/O: poses come in from odometry (or a localiser),
//! velocity commands go out. mrmm's own controller closes the loop within the kinematic limits;
//! the robot stops (zero twist) when odometry goes stale or the fleet link is lost, and goes on
//! when both are back.

use mrmm_proto::{Pose, Time, Velocity};

use crate::body::nav_goals::{Nav2Goals, NavCommand};
use crate::body::{wrap_angle, Limits, ARRIVAL_TOLERANCE};

/// Turn rate per radian of heading error, 1/s.
const TURN_GAIN: f64 = 2.0;
/// Speed per metre left near the goal, 1/s: slows down instead of overshooting.
const APPROACH_GAIN: f64 = 1.0;
/// Near the goal, drive only when facing it within this angle, radians.
const NEAR_ALIGN: f64 = 0.3;
/// Zero twists sent after a stop (a robot's own watchdog may miss one).
const STOP_REPEATS: u8 = 3;

/// Why a robot with a goal is not driving.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Halt {
    /// No odometry yet, or none for longer than the timeout.
    StaleOdometry,
    /// No link to any other node of the fleet.
    FleetLost,
}

/// What the drive tells the robot at a tick.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Step {
    /// The velocity command to publish, if any.
    pub twist: Option<Velocity>,
    /// Goals to send to Nav2 or cancel (`drive: "nav2"`).
    pub nav: Vec<NavCommand>,
    /// The goal was reached at this tick.
    pub arrived: bool,
    /// The drive started or stopped a halt at this tick (for the log).
    pub halt_changed: Option<Option<Halt>>,
}

/// The state of a ROS 2 body.
#[derive(Debug, Clone)]
pub struct RosDrive {
    limits: Limits,
    odom_timeout: f64,
    stop_on_fleet_loss: bool,
    /// Whether a localiser's pose, not odometry's, is the robot's position.
    localised: bool,
    pose: Pose,
    velocity: Velocity,
    odom_at: Option<Time>,
    goal: Option<(f64, f64)>,
    cap: Option<f64>,
    fleet_up: bool,
    zeros_left: u8,
    halt: Option<Halt>,
    /// With `drive: "nav2"`: Nav2 drives, mrmm sends it goals (and zero twists to stop).
    nav2: Option<Nav2Goals>,
    /// The robot's last battery report (`sensor_msgs/BatteryState`), if any.
    battery: Option<mrmm_proto::BatteryState>,
}

impl RosDrive {
    /// `start` is the pose reported until the first odometry arrives.
    pub fn new(start: Pose, limits: Limits, odom_timeout_s: f64, stop_on_fleet_loss: bool, localised: bool) -> Self {
        RosDrive {
            limits,
            odom_timeout: odom_timeout_s,
            stop_on_fleet_loss,
            localised,
            pose: start,
            velocity: Velocity::default(),
            odom_at: None,
            goal: None,
            cap: None,
            fleet_up: true,
            zeros_left: 0,
            halt: None,
            nav2: None,
            battery: None,
        }
    }

    /// Goals go to Nav2 instead of mrmm's controller.
    pub fn with_nav2(mut self, goals: Nav2Goals) -> Self {
        self.nav2 = Some(goals);
        self
    }

    /// The Nav2 goals, with `drive: "nav2"`.
    pub fn nav2_mut(&mut self) -> Option<&mut Nav2Goals> {
        self.nav2.as_mut()
    }

    /// The robot's battery reported: kept as the state telemetry carries.
    pub fn on_battery(&mut self, state: mrmm_proto::BatteryState) {
        self.battery = Some(state);
    }

    pub fn battery(&self) -> Option<mrmm_proto::BatteryState> {
        self.battery
    }

    /// Why the robot cannot get to its goal, while that lasts.
    pub fn stuck(&self) -> Option<&str> {
        self.nav2.as_ref().and_then(Nav2Goals::stuck)
    }

    pub fn pose(&self) -> Pose {
        self.pose
    }

    pub fn velocity(&self) -> Velocity {
        self.velocity
    }

    pub fn goal(&self) -> Option<(f64, f64)> {
        self.goal
    }

    pub fn halt(&self) -> Option<Halt> {
        self.halt
    }

    /// Odometry arrived at wall time `now`.
    pub fn on_odometry(&mut self, now: Time, pose: Pose, velocity: Velocity) {
        self.odom_at = Some(now);
        self.velocity = velocity;
        if !self.localised {
            self.pose = pose;
        }
    }

    /// The localiser's pose arrived.
    pub fn on_pose(&mut self, pose: Pose) {
        if self.localised {
            self.pose = pose;
        }
    }

    /// The fleet link came back (`true`) or was lost.
    pub fn set_fleet(&mut self, up: bool) {
        self.fleet_up = up;
    }

    pub fn navigate_capped(&mut self, x: f64, y: f64, speed: Option<f64>) {
        self.goal = Some((x, y));
        self.cap = speed.filter(|s| s.is_finite() && *s > 0.0);
    }

    pub fn hold(&mut self) {
        if self.goal.take().is_some() || self.velocity != Velocity::default() {
            self.zeros_left = STOP_REPEATS;
        }
    }

    /// One control tick at wall time `now`.
    pub fn step(&mut self, now: Time) -> Step {
        let stale = self.odom_at.is_none_or(|t| now - t > self.odom_timeout);
        let halt = if stale {
            Some(Halt::StaleOdometry)
        } else if !self.fleet_up && self.stop_on_fleet_loss {
            Some(Halt::FleetLost)
        } else {
            None
        };
        let mut out = Step::default();
        if halt != self.halt && (self.goal.is_some() || self.halt.is_some()) {
            out.halt_changed = Some(halt);
        }
        self.halt = halt;
        if let Some(n) = &mut self.nav2 {
            let (cmds, arrived) = n.step(now, self.goal, halt.is_some(), self.pose);
            out.nav = cmds;
            if arrived {
                self.goal = None;
                out.arrived = true;
                // Nav2's controller stopped the robot; mrmm's zero twists only follow a hold.
                return out;
            }
            if halt.is_some() && self.goal.is_some() {
                out.twist = Some(Velocity::default());
                return out;
            }
            return self.stopping(out);
        }
        let Some((gx, gy)) = self.goal else {
            return self.stopping(out);
        };
        if halt.is_some() {
            // Halted with a goal: zero twist at every tick until the cause is gone.
            out.twist = Some(Velocity::default());
            return out;
        }
        let (dx, dy) = (gx - self.pose.x, gy - self.pose.y);
        let dist = dx.hypot(dy);
        if dist <= ARRIVAL_TOLERANCE {
            self.goal = None;
            self.zeros_left = STOP_REPEATS;
            out.arrived = true;
            return self.stopping(out);
        }
        let err = wrap_angle(dy.atan2(dx) - self.pose.theta);
        let omega = (TURN_GAIN * err).clamp(-self.limits.max_turn_rate, self.limits.max_turn_rate);
        let max = self.cap.map_or(self.limits.max_speed, |c| c.min(self.limits.max_speed));
        let turning_radius = max / self.limits.max_turn_rate;
        let align = if dist < 2.0 * turning_radius {
            if err.abs() > NEAR_ALIGN {
                0.0
            } else {
                err.cos()
            }
        } else {
            (1.0 - err.abs() / std::f64::consts::FRAC_PI_2).clamp(0.0, 1.0)
        };
        let v = (max * align).min(APPROACH_GAIN * dist + 0.05).min(max);
        out.twist = Some(Velocity { v, omega });
        out
    }

    fn stopping(&mut self, mut out: Step) -> Step {
        if self.zeros_left > 0 {
            self.zeros_left -= 1;
            out.twist = Some(Velocity::default());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at;

    const LIM: Limits = Limits { max_speed: 1.0, max_turn_rate: 2.0 };

    /// A unicycle that follows the commands exactly, with odometry at every tick.
    fn drive_to(d: &mut RosDrive, x: f64, y: f64, ticks: usize) -> (Pose, Option<usize>) {
        let dt = 0.02;
        let mut p = d.pose();
        d.navigate_capped(x, y, None);
        for i in 0..ticks {
            let now = i as f64 * dt;
            d.on_odometry(at(now), p, Velocity::default());
            let s = d.step(at(now));
            if s.arrived {
                return (p, Some(i));
            }
            let tw = s.twist.unwrap_or_default();
            assert!(tw.v.abs() <= LIM.max_speed + 1e-9 && tw.omega.abs() <= LIM.max_turn_rate + 1e-9, "{tw:?}");
            p.theta = wrap_angle(p.theta + tw.omega * dt);
            p.x += tw.v * dt * p.theta.cos();
            p.y += tw.v * dt * p.theta.sin();
        }
        (p, None)
    }

    #[test]
    fn closes_the_loop_on_odometry_to_goals_in_every_direction() {
        for k in 0..12 {
            let a = k as f64 * std::f64::consts::TAU / 12.0;
            for r in [0.3, 2.0, 6.0] {
                let mut d = RosDrive::new(Pose::default(), LIM, 0.5, true, false);
                let (p, arrived) = drive_to(&mut d, r * a.cos(), r * a.sin(), 3000);
                assert!(arrived.is_some(), "bearing {a:.2}, {r} m: stuck at {p:?}");
                assert!(d.goal().is_none());
                assert_eq!(d.step(at(100.0)).twist, Some(Velocity::default()), "a zero twist after arriving");
            }
        }
    }

    #[test]
    fn stale_odometry_and_a_lost_fleet_stop_the_robot_until_they_are_back() {
        let mut d = RosDrive::new(Pose::default(), LIM, 0.5, true, false);
        d.navigate_capped(5.0, 0.0, None);
        assert_eq!(d.step(at(0.0)).twist, Some(Velocity::default()), "no odometry yet: no motion");
        d.on_odometry(at(1.0), Pose::default(), Velocity::default());
        let s = d.step(at(1.1));
        assert!(s.twist.is_some_and(|t| t.v > 0.0), "{s:?}");
        assert_eq!(s.halt_changed, Some(None));
        let s = d.step(at(1.6));
        assert_eq!((s.twist, s.halt_changed), (Some(Velocity::default()), Some(Some(Halt::StaleOdometry))), "odometry 0.6 s old");
        d.on_odometry(at(1.7), Pose::default(), Velocity::default());
        assert!(d.step(at(1.7)).twist.is_some_and(|t| t.v > 0.0));
        d.set_fleet(false);
        let s = d.step(at(1.72));
        assert_eq!((s.twist, s.halt_changed), (Some(Velocity::default()), Some(Some(Halt::FleetLost))));
        assert_eq!(d.goal(), Some((5.0, 0.0)), "the goal stays");
        d.set_fleet(true);
        assert!(d.step(at(1.74)).twist.is_some_and(|t| t.v > 0.0));
        // Configured to drive on without the fleet.
        let mut free = RosDrive::new(Pose::default(), LIM, 0.5, false, false);
        free.navigate_capped(5.0, 0.0, None);
        free.on_odometry(at(0.0), Pose::default(), Velocity::default());
        free.set_fleet(false);
        assert!(free.step(at(0.1)).twist.is_some_and(|t| t.v > 0.0));
    }

    #[test]
    fn hold_sends_a_few_zero_twists_then_nothing() {
        let mut d = RosDrive::new(Pose::default(), LIM, 0.5, true, false);
        d.on_odometry(at(0.0), Pose::default(), Velocity::default());
        d.navigate_capped(5.0, 0.0, None);
        assert!(d.step(at(0.0)).twist.is_some());
        d.hold();
        let zeros: Vec<_> = (0..5).map(|i| d.step(at(0.02 * f64::from(i))).twist).collect();
        assert_eq!(zeros, vec![Some(Velocity::default()); 3].into_iter().chain([None, None]).collect::<Vec<_>>());
    }

    #[test]
    fn a_localiser_pose_wins_over_odometry() {
        let mut d = RosDrive::new(Pose::default(), LIM, 0.5, true, true);
        d.on_odometry(at(0.0), Pose { x: 9.0, y: 9.0, theta: 0.0 }, Velocity { v: 0.3, omega: 0.0 });
        assert_eq!(d.pose(), Pose::default());
        d.on_pose(Pose { x: 1.0, y: 2.0, theta: 0.5 });
        assert_eq!(d.pose(), Pose { x: 1.0, y: 2.0, theta: 0.5 });
        assert_eq!(d.velocity().v, 0.3);
    }
}
