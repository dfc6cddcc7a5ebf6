//! Central's journal on disk: every change of the system manager's durable state and its history,
//! in an embedded ACID database (redb: pure Rust, crash-safe copy-on-write B-trees, every commit
//! fsynced). One table maps sequence numbers to JSON entries ([`JournalEntry`]); central replays
//! the state on start ([`Journal::open`]) and appends what each event changed before it carries
//! out anything else ([`Journal::append`]).
//!
//! **Compaction.** Every [`COMPACT_EVERY`] entries, the append's transaction also writes a
//! snapshot of the durable state (the state entries that rebuild it, as of the last sequence
//! number) and deletes entries older than the last [`KEEP_HISTORY`]; the file is then compacted.
//! Start-up replays the snapshot and the entries after it, so the journal's size and central's
//! start-up time are bounded by the fleet's state, not its history: a central that ran a month
//! starts as fast as one that ran a minute. Operators read the history kept
//! (`mrmm/system/journal`); sequence numbers go on from where they were.

use std::path::{Path, PathBuf};

use mrmm_proto::journal::JOURNAL_PAGE;
use mrmm_proto::{JournalEntry, JournalEvent, JournalPage};
use redb::{Database, ReadableDatabase, TableDefinition};

use crate::error::ManagerError;
use mrmm_core::central::system::Durable;

const ENTRIES: TableDefinition<u64, &[u8]> = TableDefinition::new("entries");
/// One row, key 0: the [`Snapshot`].
const SNAPSHOT: TableDefinition<u8, &[u8]> = TableDefinition::new("snapshot");

/// Entries appended between two snapshots.
pub const COMPACT_EVERY: u64 = 10_000;
/// Entries kept for the operator behind a snapshot (older ones are deleted).
pub const KEEP_HISTORY: u64 = 10_000;

/// The durable state as of entry `seq`: the state entries that rebuild it from nothing.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
struct Snapshot {
    seq: u64,
    state: Vec<JournalEvent>,
}

/// The database file inside the state directory.
pub const FILE: &str = "journal.redb";

/// Wall-clock time, milliseconds since the Unix epoch (what entries are stamped with).
pub fn now_ms() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_millis() as u64)
}

/// The journal, open.
pub struct Journal {
    db: Database,
    path: PathBuf,
    last: u64,
    /// The sequence number of the latest snapshot (0: none).
    snapshot: u64,
    /// The durable state as of `last` (what the next snapshot holds).
    state: Durable,
}

impl std::fmt::Debug for Journal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Journal").field("path", &self.path).field("last", &self.last).finish()
    }
}

impl Journal {
    /// Opens (or creates) the journal in `dir` and replays it: the durable state it holds (its
    /// snapshot, then the entries after it), and how many entries it has. A damaged file or
    /// entry stops here with a readable error.
    pub fn open(dir: &Path) -> Result<(Journal, Durable), ManagerError> {
        std::fs::create_dir_all(dir).map_err(|e| ManagerError::journal(format!("state dir {}", dir.display()), e))?;
        let path = dir.join(FILE);
        let err = |what: &str, e: mrmm_proto::BoxError| ManagerError::journal(format!("journal {}: {what}", path.display()), e);
        let db = Database::create(&path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => err("open", "another central uses this state dir".into()),
            e => err("open", e.into()),
        })?;
        // The tables exist from the start, so readers never miss them.
        let w = db.begin_write().map_err(|e| err("write", e.into()))?;
        w.open_table(ENTRIES).map_err(|e| err("write", e.into()))?;
        w.open_table(SNAPSHOT).map_err(|e| err("write", e.into()))?;
        w.commit().map_err(|e| err("commit", e.into()))?;
        let r = db.begin_read().map_err(|e| err("read", e.into()))?;
        let mut state = Durable::default();
        let snapshot = r.open_table(SNAPSHOT).map_err(|e| err("read", e.into()))?;
        let mut from = 0;
        if let Some(v) = snapshot.get(0).map_err(|e| err("read", e.into()))? {
            let snap: Snapshot = serde_json::from_slice(v.value()).map_err(|e| err("snapshot", e.into()))?;
            for e in &snap.state {
                state.apply(e);
            }
            from = snap.seq;
        }
        let table = r.open_table(ENTRIES).map_err(|e| err("read", e.into()))?;
        let mut last = from;
        for item in table.range(from.saturating_add(1)..).map_err(|e| err("read", e.into()))? {
            let (k, v) = item.map_err(|e| err("read", e.into()))?;
            let seq = k.value();
            let entry: JournalEntry = serde_json::from_slice(v.value()).map_err(|e| err(&format!("entry {seq}"), e.into()))?;
            state.apply(&entry.event);
            last = seq;
        }
        drop(table);
        drop(snapshot);
        drop(r);
        let journal = Journal { db, path, last, snapshot: from, state: state.clone() };
        Ok((journal, state))
    }

    /// The last sequence number committed.
    pub fn last(&self) -> u64 {
        self.last
    }

    /// Commits `events` as one transaction, durable (fsync) when this returns; `at_ms` is the
    /// wall-clock time stamped on them. Every [`COMPACT_EVERY`] entries the same transaction
    /// writes a snapshot and drops the history beyond [`KEEP_HISTORY`] (then the file is
    /// compacted).
    pub fn append(&mut self, events: &[JournalEvent], at_ms: u64) -> Result<u64, ManagerError> {
        let err = |what: &str, e: mrmm_proto::BoxError| ManagerError::journal(format!("journal {}: {what}", self.path.display()), e);
        let w = self.db.begin_write().map_err(|e| err("write", e.into()))?;
        let mut seq = self.last;
        {
            let mut table = w.open_table(ENTRIES).map_err(|e| err("write", e.into()))?;
            for event in events {
                seq = seq.checked_add(1).ok_or_else(|| err("write", "sequence numbers exhausted".into()))?;
                let entry = JournalEntry { seq, at_ms, event: event.clone() };
                let bytes = serde_json::to_vec(&entry).map_err(|e| err("encode", e.into()))?;
                table.insert(seq, bytes.as_slice()).map_err(|e| err("write", e.into()))?;
            }
        }
        let mut state = self.state.clone();
        for e in events.iter().filter(|e| e.is_state()) {
            state.apply(e);
        }
        let snapshot = seq - self.snapshot >= COMPACT_EVERY;
        if snapshot {
            let snap = Snapshot { seq, state: Durable::default().diff(&state) };
            let bytes = serde_json::to_vec(&snap).map_err(|e| err("encode", e.into()))?;
            w.open_table(SNAPSHOT).map_err(|e| err("write", e.into()))?.insert(0, bytes.as_slice()).map_err(|e| err("write", e.into()))?;
            let keep_from = seq.saturating_sub(KEEP_HISTORY);
            w.open_table(ENTRIES).map_err(|e| err("write", e.into()))?.retain_in(..keep_from, |_, _| false).map_err(|e| err("write", e.into()))?;
        }
        w.commit().map_err(|e| err("commit", e.into()))?;
        self.last = seq;
        self.state = state;
        if snapshot {
            self.snapshot = seq;
            // The space the deleted entries held goes back to the file system (best effort).
            if let Err(e) = self.db.compact() {
                tracing::warn!(path = %self.path.display(), "journal compaction: {e}");
            }
            tracing::info!(path = %self.path.display(), seq, "journal snapshot written, history beyond {KEEP_HISTORY} entries dropped");
        }
        Ok(seq)
    }

    /// Entries after `since`, oldest first, at most `limit` (capped at [`JOURNAL_PAGE`]).
    pub fn page(&self, since: u64, limit: usize) -> Result<JournalPage, ManagerError> {
        let err = |e: mrmm_proto::BoxError| ManagerError::journal(format!("journal {}: read", self.path.display()), e);
        let limit = limit.clamp(1, JOURNAL_PAGE);
        let r = self.db.begin_read().map_err(|e| err(e.into()))?;
        let table = r.open_table(ENTRIES).map_err(|e| err(e.into()))?;
        let mut entries = Vec::new();
        let from = since.saturating_add(1);
        for item in table.range(from..).map_err(|e| err(e.into()))?.take(limit) {
            let (k, v) = item.map_err(|e| err(e.into()))?;
            let entry: JournalEntry = serde_json::from_slice(v.value())
                .map_err(|e| ManagerError::journal(format!("journal {}: read: entry {}", self.path.display(), k.value()), e))?;
            entries.push(entry);
        }
        let next = entries.last().map_or(since, |e| e.seq);
        Ok(JournalPage { more: next < self.last, entries, last: self.last, next })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_proto::RobotId;

    #[test]
    fn what_is_appended_is_replayed_after_a_reopen_and_paged() {
        let dir = tempfile::tempdir().expect("tmp");
        let (mut j, state) = Journal::open(dir.path()).expect("open");
        assert_eq!((j.last(), state), (0, Durable::default()));
        let events = vec![
            JournalEvent::MissionDefined {
                mission: "p".into(),
                host: "central".into(),
                recipe: "patrol".into(),
                planner: "patrol".into(),
                spec: None,
                lineage: 1,
            },
            JournalEvent::RobotAssigned { robot: "r1".into(), mission: Some("p".into()) },
            JournalEvent::RobotLost { robot: "r1".into() },
        ];
        assert_eq!(j.append(&events, 5).expect("append"), 3);
        assert_eq!(j.append(&[JournalEvent::MissionRemoved { mission: "q".into(), terminated: true }], 6).expect("append"), 4);
        // A second central on the same directory is refused while this one runs.
        let e = Journal::open(dir.path()).expect_err("locked");
        assert!(e.to_string().contains("another central uses this state dir"), "{e}");
        drop(j);
        let (j, state) = Journal::open(dir.path()).expect("reopen");
        assert_eq!(j.last(), 4);
        assert_eq!(state.assignment.get("r1").map(|m| m.as_str()), Some("p"));
        assert!(state.missions.contains_key("p") && state.terminated.contains("q"));
        let page = j.page(1, 2).expect("page");
        assert_eq!(page.entries.iter().map(|e| e.seq).collect::<Vec<_>>(), [2, 3]);
        assert_eq!((page.next, page.last, page.more), (3, 4, true));
        let page = j.page(page.next, 100).expect("page");
        assert_eq!((page.entries.len(), page.more), (1, false));
        assert_eq!(page.entries[0].at_ms, 6);
    }

    /// Issue 50: the journal was never compacted and was replayed whole at start. 100 000
    /// losses and returns later, it holds a snapshot and the last entries, and reopens with the
    /// same state.
    #[test]
    fn a_long_history_is_compacted_into_a_snapshot_and_the_last_entries() {
        let dir = tempfile::tempdir().expect("tmp");
        let (mut j, _) = Journal::open(dir.path()).expect("open");
        let defined = |m: &str| JournalEvent::MissionDefined {
            mission: m.into(),
            host: "central".into(),
            recipe: "patrol".into(),
            planner: "patrol".into(),
            spec: None,
            lineage: 0,
        };
        j.append(&[defined("p"), defined("gone"), JournalEvent::RobotAssigned { robot: "r1".into(), mission: Some("p".into()) }], 1).expect("append");
        // 2 500 commits of 20 losses and returns each (one fsync per commit).
        for k in 0..2_500u64 {
            let batch: Vec<JournalEvent> = (0..20)
                .flat_map(|i| {
                    let r = RobotId::from(format!("r{}", (k * 20 + i) % 300));
                    [JournalEvent::RobotLost { robot: r.clone() }, JournalEvent::RobotBack { robot: r }]
                })
                .collect();
            j.append(&batch, k).expect("append");
            if k == 1_000 {
                j.append(&[JournalEvent::MissionRemoved { mission: "gone".into(), terminated: true }], k).expect("append");
            }
        }
        let last = j.last();
        assert_eq!(last, 100_004);
        drop(j);
        let size = std::fs::metadata(dir.path().join(FILE)).expect("file").len();
        assert!(size <= 10 << 20, "{size} bytes");
        let t0 = std::time::Instant::now();
        let (j, state) = Journal::open(dir.path()).expect("reopen");
        eprintln!("journal of {last} entries: {size} bytes, reopened in {:?}", t0.elapsed());
        assert_eq!(j.last(), last, "sequence numbers go on");
        assert_eq!(state.assignment.get("r1").map(|m| m.as_str()), Some("p"));
        assert!(state.missions.contains_key("p") && !state.missions.contains_key("gone") && state.terminated.contains("gone"));
        let page = j.page(0, 10).expect("page");
        let first = page.entries.first().map(|e| e.seq).expect("history kept");
        assert!(first > last - KEEP_HISTORY - COMPACT_EVERY && first <= last - KEEP_HISTORY + 1, "{first}");
    }

    #[test]
    fn a_damaged_file_is_a_readable_error() {
        let dir = tempfile::tempdir().expect("tmp");
        std::fs::write(dir.path().join(FILE), b"not a database at all, just some bytes").expect("write");
        let e = Journal::open(dir.path()).expect_err("damaged");
        assert!(e.to_string().starts_with("journal "), "{e}");
    }
}
