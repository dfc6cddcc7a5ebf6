//! Creates and updates waiting for their dry run: checked in full on central's loop, planned
//! off it by the driver, and taking effect when the dry run is done.

use std::collections::BTreeMap;

use mrmm_proto::{MissionCreate, MissionUpdate};

use super::Req;

/// A command waiting for its dry run.
#[derive(Debug, Clone)]
pub(super) enum Checking {
    Create(MissionCreate),
    Update(MissionUpdate),
}

/// The commands waiting for their dry run, by check id.
#[derive(Debug, Clone, Default)]
pub(super) struct DryRuns {
    next: u64,
    waiting: BTreeMap<u64, (Req, Checking)>,
}

impl DryRuns {
    /// Holds `checking` for `req` until its dry run is done; returns the check's id.
    pub fn push(&mut self, req: Req, checking: Checking) -> u64 {
        let id = self.next;
        self.next += 1;
        self.waiting.insert(id, (req, checking));
        id
    }

    /// The command whose dry run `id` is done (None: not one of ours, or answered already).
    pub fn take(&mut self, id: u64) -> Option<(Req, Checking)> {
        self.waiting.remove(&id)
    }
}
