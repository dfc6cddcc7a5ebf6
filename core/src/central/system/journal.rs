//! What the system manager owes its journal: the durable state as last committed, and the
//! history noted since (robots lost and back, managers moved, commands, restarts).

use mrmm_proto::JournalEvent;

use super::Durable;

/// The journal as the system manager sees it.
#[derive(Debug, Clone, Default)]
pub(super) struct Journal {
    /// What the journal holds (as of the last [`super::Command::Journal`]).
    committed: Durable,
    /// History for the journal, out with the next [`super::Command::Journal`].
    notes: Vec<JournalEvent>,
}

impl Journal {
    /// A journal that holds `state`.
    pub(super) fn holding(state: Durable) -> Journal {
        Journal { committed: state, notes: Vec::new() }
    }

    /// History to commit with the next entries.
    pub(super) fn note(&mut self, e: JournalEvent) {
        self.notes.push(e);
    }

    /// What the journal holds.
    pub(super) fn committed(&self) -> &Durable {
        &self.committed
    }

    /// The entries to commit: those that take what the journal holds to `now` (when the durable
    /// state changed), then the history noted meanwhile. `now` is then what it holds.
    pub(super) fn entries(&mut self, now: Option<Durable>) -> Vec<JournalEvent> {
        let mut entries = Vec::new();
        if let Some(now) = now {
            entries = self.committed.diff(&now);
            self.committed = now;
        }
        entries.append(&mut self.notes);
        entries
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changes_come_before_the_history_noted_and_are_committed_once() {
        let mut j = Journal::default();
        j.note(JournalEvent::RobotLost { robot: "r1".into() });
        let mut now = Durable::default();
        now.assignment.insert("r2".into(), "p".into());
        let e = j.entries(Some(now.clone()));
        assert_eq!(e, vec![JournalEvent::RobotAssigned { robot: "r2".into(), mission: Some("p".into()) }, JournalEvent::RobotLost { robot: "r1".into() }]);
        assert_eq!(j.committed(), &now);
        assert!(j.entries(None).is_empty(), "nothing new: nothing to commit");
    }
}
