//! A value that remembers whether it may have changed since it was last committed: read freely,
//! and any mutable access marks it. Central's journal diffs the durable part after every event;
//! comparing the whole robot → mission map each time cost O(N) per event (a telemetry sample of
//! one robot compared all N entries). Now only an event that touched it pays for the comparison.

use std::ops::{Deref, DerefMut};

#[derive(Debug, Clone, Default)]
pub(super) struct Touched<T> {
    value: T,
    touched: bool,
}

impl<T> Touched<T> {
    /// A value as committed (untouched).
    pub(super) fn new(value: T) -> Self {
        Touched { value, touched: false }
    }

    /// Whether it was accessed mutably since [`Touched::committed`].
    pub(super) fn touched(&self) -> bool {
        self.touched
    }

    /// What it holds now is what the journal holds.
    pub(super) fn committed(&mut self) {
        self.touched = false;
    }
}

impl<T> Deref for Touched<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.value
    }
}

impl<T> DerefMut for Touched<T> {
    fn deref_mut(&mut self) -> &mut T {
        self.touched = true;
        &mut self.value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_leave_it_untouched_and_a_mutable_access_marks_it_until_committed() {
        let mut m = Touched::new(std::collections::BTreeMap::from([(1, 2)]));
        assert_eq!(m.get(&1), Some(&2));
        assert!(!m.touched());
        m.insert(3, 4);
        assert!(m.touched());
        m.committed();
        assert!(!m.touched());
        m.retain(|_, _| true);
        assert!(m.touched(), "any mutable access counts, even one that changed nothing");
    }
}
