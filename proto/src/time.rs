//! Time as every machine sees it: an instant on its node's clock ([`Time`], seconds since the
//! node's epoch); a span between two instants stays plain seconds (`f64`), so `now - since > 2.0`
//! reads as it means and an instant can never be passed where a span is expected, or back.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::{Add, AddAssign, Sub, SubAssign};

/// An instant, in seconds on its node's clock. Serialized as the bare number of seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Time(f64);

impl Time {
    /// The node's epoch.
    pub const ZERO: Time = Time(0.0);
    /// Later than any instant (a deadline that never comes).
    pub const NEVER: Time = Time(f64::INFINITY);
    /// Earlier than any instant (what was never done was done this long ago).
    pub const LONG_AGO: Time = Time(f64::NEG_INFINITY);

    /// The instant `secs` seconds after the epoch.
    pub const fn from_secs(secs: f64) -> Time {
        Time(secs)
    }

    /// Seconds since the epoch.
    pub const fn secs(self) -> f64 {
        self.0
    }

    /// Seconds from `earlier` to `self` (negative when `earlier` is later).
    pub fn since(self, earlier: Time) -> f64 {
        self.0 - earlier.0
    }

    /// The later of two instants.
    pub fn max(self, other: Time) -> Time {
        Time(self.0.max(other.0))
    }

    /// The earlier of two instants.
    pub fn min(self, other: Time) -> Time {
        Time(self.0.min(other.0))
    }

    /// Orders instants totally (as [`f64::total_cmp`]), for sorting.
    pub fn total_cmp(&self, other: &Time) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }

    /// Whether the instant is a finite one (not [`Time::NEVER`], not NaN).
    pub fn is_finite(self) -> bool {
        self.0.is_finite()
    }
}

impl Add<f64> for Time {
    type Output = Time;
    fn add(self, span: f64) -> Time {
        Time(self.0 + span)
    }
}

impl AddAssign<f64> for Time {
    fn add_assign(&mut self, span: f64) {
        self.0 += span;
    }
}

impl Sub<f64> for Time {
    type Output = Time;
    fn sub(self, span: f64) -> Time {
        Time(self.0 - span)
    }
}

impl SubAssign<f64> for Time {
    fn sub_assign(&mut self, span: f64) {
        self.0 -= span;
    }
}

/// The span between two instants, in seconds.
impl Sub<Time> for Time {
    type Output = f64;
    fn sub(self, earlier: Time) -> f64 {
        self.0 - earlier.0
    }
}

impl fmt::Display for Time {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3} s", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instants_and_spans_do_not_mix() {
        let t = Time::from_secs(10.0);
        let later = t + 2.5;
        assert_eq!(later - t, 2.5);
        assert_eq!(later.since(t), 2.5);
        assert_eq!(t - 1.0, Time::from_secs(9.0));
        assert!(t < later && Time::NEVER > later);
        assert_eq!(t.max(later), later);
        assert_eq!(t.min(later), t);
        assert!(!Time::NEVER.is_finite() && t.is_finite() && Time::LONG_AGO < t);
    }

    #[test]
    fn serialized_as_bare_seconds() {
        assert_eq!(serde_json::to_string(&Time::from_secs(1.5)).expect("json"), "1.5");
        let t: Time = serde_json::from_str("2.25").expect("json");
        assert_eq!(t, Time::from_secs(2.25));
        assert_eq!(Time::from_secs(3.0).to_string(), "3.000 s");
    }
}
