//! A simulated robot's battery: energy drained by distance driven, turning and time (the
//! computer and sensors draw power standing still too), and put back at a charger; its charge,
//! whether it charges and how far it still reaches travel in telemetry
//! ([`mrmm_proto::BatteryState`]).

use mrmm_proto::BatteryState;

/// How a battery drains and charges. Energies in watt-hours, powers in watts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BatteryModel {
    /// Energy of a full charge, Wh.
    pub capacity_wh: f64,
    /// Energy per metre driven, Wh/m.
    pub per_metre_wh: f64,
    /// Energy per radian turned, Wh/rad.
    pub per_radian_wh: f64,
    /// Power drawn all the time, driving or not, W.
    pub idle_w: f64,
    /// Power a charger puts in, W.
    pub charge_w: f64,
}

/// Share of a battery's power, driving at top speed, that its idle draw takes (the rest goes
/// into driving) in [`BatteryModel::lasting`].
const IDLE_SHARE: f64 = 0.2;
/// A charge from empty to full takes this share of a full charge's driving time, in
/// [`BatteryModel::lasting`] (fleet robots charge about 3 times faster than they drain).
const CHARGE_SHARE: f64 = 1.0 / 3.0;
/// Below this share of its capacity a battery counts as empty (rounding leaves crumbs).
const EMPTY: f64 = 1e-9;
/// Capacity [`BatteryModel::lasting`] gives (only ratios matter to the robot), Wh.
const LASTING_WH: f64 = 100.0;

impl BatteryModel {
    /// A battery that a full charge lets drive `seconds` at `speed` (m/s), a fifth of its power
    /// drawn standing still too; charged from empty in a third of that time. For demonstrations
    /// (`mrmm demo --battery-life S`): a robot's day in minutes.
    pub fn lasting(seconds: f64, speed: f64) -> BatteryModel {
        let power = LASTING_WH * 3600.0 / seconds;
        BatteryModel {
            capacity_wh: LASTING_WH,
            per_metre_wh: (1.0 - IDLE_SHARE) * power / speed / 3600.0,
            per_radian_wh: 0.0,
            idle_w: IDLE_SHARE * power,
            charge_w: LASTING_WH * 3600.0 / (seconds * CHARGE_SHARE),
        }
    }

    /// Checks the model: a positive finite capacity and charge power, finite non-negative
    /// consumptions, not all of them zero. The error names the field.
    pub fn check(&self) -> Result<(), String> {
        let positive = [("capacity_wh", self.capacity_wh), ("charge_w", self.charge_w)];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name}: must be a positive number, got {v}"));
            }
        }
        let draws = [("per_metre_wh", self.per_metre_wh), ("per_radian_wh", self.per_radian_wh), ("idle_w", self.idle_w)];
        for (name, v) in draws {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name}: must be zero or more, got {v}"));
            }
        }
        if self.per_metre_wh == 0.0 && self.idle_w == 0.0 {
            return Err("per_metre_wh and idle_w: a battery that never drains is no battery (leave the section out)".into());
        }
        Ok(())
    }

    /// Energy per metre driven at `speed` (m/s), the idle draw over the time it takes counted.
    fn per_metre_at(&self, speed: f64) -> f64 {
        self.per_metre_wh + self.idle_w / 3600.0 / speed.max(mrmm_proto::MIN_SPEED)
    }
}

/// A battery: its model, the energy it holds, and whether it is charging.
#[derive(Debug, Clone, PartialEq)]
pub struct Battery {
    model: BatteryModel,
    energy_wh: f64,
    charging: bool,
}

impl Battery {
    /// A battery of `model` at `charge` (0–1, clamped).
    pub fn new(model: BatteryModel, charge: f64) -> Battery {
        let charge = if charge.is_finite() { charge.clamp(0.0, 1.0) } else { 1.0 };
        Battery { model, energy_wh: model.capacity_wh * charge, charging: false }
    }

    pub fn model(&self) -> &BatteryModel {
        &self.model
    }

    /// State of charge, 0–1.
    pub fn charge(&self) -> f64 {
        (self.energy_wh / self.model.capacity_wh).clamp(0.0, 1.0)
    }

    /// Nothing left: the robot cannot drive.
    pub fn empty(&self) -> bool {
        self.energy_wh <= EMPTY * self.model.capacity_wh
    }

    pub fn charging(&self) -> bool {
        self.charging
    }

    /// Starts or stops charging (the robot stands at a charger).
    pub fn set_charging(&mut self, on: bool) {
        self.charging = on;
    }

    /// `dt` seconds passed in which the robot drove `metres` and turned `radians`: drains what
    /// that took, or (charging) puts in what the charger gave less the idle draw.
    pub fn pass(&mut self, dt: f64, metres: f64, radians: f64) {
        let (dt, metres, radians) = (dt.max(0.0), metres.abs(), radians.abs());
        let m = &self.model;
        let drawn = m.idle_w * dt / 3600.0 + m.per_metre_wh * metres + m.per_radian_wh * radians;
        let given = if self.charging { m.charge_w * dt / 3600.0 } else { 0.0 };
        let e = self.energy_wh + given - drawn;
        self.energy_wh = if e.is_finite() { e.clamp(0.0, m.capacity_wh) } else { 0.0 };
    }

    /// How far the charge left takes the robot at `speed` (m/s), metres.
    pub fn reach_m(&self, speed: f64) -> f64 {
        (self.energy_wh / self.model.per_metre_at(speed)).min(mrmm_proto::MAX_REACH_M)
    }

    /// The state telemetry carries, at top speed `speed`.
    pub fn state(&self, speed: f64) -> BatteryState {
        BatteryState { charge: self.charge(), charging: self.charging, reach_m: Some(self.reach_m(speed)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lasting_battery_drives_its_seconds_at_top_speed_and_charges_in_a_third() {
        let m = BatteryModel::lasting(600.0, 2.0);
        m.check().expect("valid");
        let mut b = Battery::new(m, 1.0);
        assert!((b.reach_m(2.0) - 1200.0).abs() < 1e-6, "{}", b.reach_m(2.0));
        // 599 s of driving at 2 m/s leaves a sliver; the 600th second empties it.
        for _ in 0..599 {
            b.pass(1.0, 2.0, 0.0);
        }
        assert!(!b.empty() && b.charge() < 0.01, "{}", b.charge());
        b.pass(1.0, 2.0, 0.0);
        assert!(b.empty());
        b.set_charging(true);
        for _ in 0..200 {
            b.pass(1.0, 0.0, 0.0);
        }
        // The idle draw goes on while it charges: not quite full after a third of 600 s.
        assert!(b.charge() > 0.9 && b.charge() < 1.0, "{}", b.charge());
        for _ in 0..100 {
            b.pass(1.0, 0.0, 0.0);
        }
        assert_eq!(b.charge(), 1.0, "full, and never more");
        assert!(b.state(2.0).charging);
    }

    #[test]
    fn standing_still_drains_the_idle_draw_only() {
        let m = BatteryModel { capacity_wh: 10.0, per_metre_wh: 1.0, per_radian_wh: 0.5, idle_w: 36.0, charge_w: 100.0 };
        let mut b = Battery::new(m, 1.0);
        b.pass(100.0, 0.0, 0.0);
        assert!((b.charge() - 0.9).abs() < 1e-9, "36 W for 100 s is 1 Wh of 10");
        b.pass(0.0, 2.0, 2.0);
        assert!((b.charge() - 0.6).abs() < 1e-9, "2 m and 2 rad: 3 Wh");
        // Reach at 1 m/s: each metre costs 1 Wh driving and 0.01 Wh idle.
        assert!((b.reach_m(1.0) - 6.0 / 1.01).abs() < 1e-9);
        b.pass(f64::INFINITY, f64::NAN, 0.0);
        assert!(b.empty(), "non-finite input empties, never poisons the state");
        assert_eq!(b.charge(), 0.0);
    }

    #[test]
    fn a_model_that_cannot_work_names_its_field() {
        let good = BatteryModel::lasting(60.0, 1.0);
        assert!(BatteryModel { capacity_wh: 0.0, ..good }.check().expect_err("zero").starts_with("capacity_wh"));
        assert!(BatteryModel { charge_w: f64::NAN, ..good }.check().expect_err("nan").starts_with("charge_w"));
        assert!(BatteryModel { per_radian_wh: -1.0, ..good }.check().expect_err("neg").starts_with("per_radian_wh"));
        let never = BatteryModel { per_metre_wh: 0.0, idle_w: 0.0, ..good };
        assert!(never.check().expect_err("never drains").contains("never drains"));
        assert_eq!(Battery::new(good, 7.0).charge(), 1.0);
        assert_eq!(Battery::new(good, f64::NAN).charge(), 1.0);
    }
}
