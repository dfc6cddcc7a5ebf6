//! A live node's clock for its machine: the seconds since the node's loop started, as the
//! [`Time`] every machine's `handle(now, …)` takes (the simulations keep their own).

use std::time::Instant;

use mrmm_proto::Time;

/// Time since the node started; copied into each event its loop hands the machine.
#[derive(Debug, Clone, Copy)]
pub struct Clock(Instant);

impl Clock {
    /// A clock that reads [`Time::ZERO`] now.
    pub fn start() -> Clock {
        Clock(Instant::now())
    }

    /// The time now: seconds since [`Clock::start`].
    pub fn now(&self) -> Time {
        Time::from_secs(self.0.elapsed().as_secs_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_starts_at_zero_and_never_goes_back() {
        let c = Clock::start();
        let a = c.now();
        let b = c.now();
        assert!(a >= Time::ZERO && b >= a, "{a:?} then {b:?}");
        assert!(a.secs() < 1.0, "a clock just started reads {a:?}");
    }
}
