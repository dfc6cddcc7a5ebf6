//! A durable host's chain state on disk: for every mission this node replicates (or remembers),
//! what its replica must keep across a restart ([`chain::Disk`]: promise, vote, configuration,
//! newest state), in an embedded ACID database (redb, like central's journal; one fsynced
//! transaction per write), so a robot that crashes and restarts can never vote twice in an epoch
//! nor forget a state it acknowledged.

use std::path::{Path, PathBuf};

use mrmm_proto::MissionSnapshot;
use redb::{Database, ReadableDatabase, ReadableTable, TableDefinition};

use crate::error::ManagerError;
use mrmm_core::mission::chain::Disk;

const CHAIN: TableDefinition<&str, &[u8]> = TableDefinition::new("chain");

/// The database file inside the state directory.
pub const FILE: &str = "chain.redb";

/// One mission's entry.
pub type Entry = (String, Disk<MissionSnapshot>);
/// A store just opened, with what it held.
pub type Opened = (Store, Vec<Entry>);

/// The store, open.
pub struct Store {
    db: Database,
    path: PathBuf,
}

impl std::fmt::Debug for Store {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Store").field("path", &self.path).finish()
    }
}

impl Store {
    /// Opens (or creates) the store in `dir` and reads everything it holds. A damaged file, an
    /// entry that does not decode, or another process using the directory stops here with a
    /// readable error.
    pub fn open(dir: &Path) -> Result<Opened, ManagerError> {
        std::fs::create_dir_all(dir).map_err(|e| ManagerError::journal(format!("state dir {}", dir.display()), e))?;
        let path = dir.join(FILE);
        let err = |what: &str, e: mrmm_proto::BoxError| ManagerError::journal(format!("chain state {}: {what}", path.display()), e);
        let db = Database::create(&path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => err("open", "another process uses this state dir".into()),
            e => err("open", e.into()),
        })?;
        let w = db.begin_write().map_err(|e| err("write", e.into()))?;
        w.open_table(CHAIN).map_err(|e| err("write", e.into()))?;
        w.commit().map_err(|e| err("commit", e.into()))?;
        let r = db.begin_read().map_err(|e| err("read", e.into()))?;
        let table = r.open_table(CHAIN).map_err(|e| err("read", e.into()))?;
        let mut entries = Vec::new();
        for item in table.iter().map_err(|e| err("read", e.into()))? {
            let (k, v) = item.map_err(|e| err("read", e.into()))?;
            let name = k.value().to_string();
            let disk: Disk<MissionSnapshot> = serde_json::from_slice(v.value()).map_err(|e| err(&format!("mission {name:?}"), e.into()))?;
            entries.push((name, disk));
        }
        drop(table);
        drop(r);
        Ok((Store { db, path }, entries))
    }

    /// Writes what `mission`'s replica must keep (or forgets it), synced to disk on return.
    pub fn write(&self, mission: &str, disk: &Disk<MissionSnapshot>) -> Result<(), ManagerError> {
        let err = |what: &str, e: mrmm_proto::BoxError| ManagerError::journal(format!("chain state {}: {what}", self.path.display()), e);
        let w = self.db.begin_write().map_err(|e| err("write", e.into()))?;
        {
            let mut t = w.open_table(CHAIN).map_err(|e| err("write", e.into()))?;
            match disk {
                Disk::Forget => {
                    t.remove(mission).map_err(|e| err("write", e.into()))?;
                }
                d => {
                    let bytes = serde_json::to_vec(d).map_err(|e| err("encode", e.into()))?;
                    t.insert(mission, bytes.as_slice()).map_err(|e| err("write", e.into()))?;
                }
            }
        }
        w.commit().map_err(|e| err("commit", e.into()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mrmm_core::mission::chain::{Config, Stored, Tomb};

    #[test]
    fn what_is_written_is_read_back_and_a_second_opener_is_refused() {
        let dir = std::env::temp_dir().join(format!("mrmm-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        {
            let (s, got) = Store::open(&dir).expect("open");
            assert!(got.is_empty());
            let stored = Stored {
                promised: 7,
                voted_for: Some("r2".into()),
                config: Some(Config { epoch: 7, chain: vec!["r2".into(), "r1".into()] }),
                state: None,
                ended: false,
            };
            s.write("p", &Disk::Replica(stored)).expect("write");
            s.write("q", &Disk::Tomb(Tomb { promised: 3, ended: true })).expect("write");
            s.write("x", &Disk::Tomb(Tomb { promised: 1, ended: false })).expect("write");
            s.write("x", &Disk::Forget).expect("forget");
            let e = Store::open(&dir).expect_err("second opener");
            assert!(e.to_string().contains("another process uses this state dir"), "{e}");
        }
        let (_s, got) = Store::open(&dir).expect("reopen");
        let names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["p", "q"]);
        assert!(matches!(&got[0].1, Disk::Replica(s) if s.promised == 7 && s.voted_for.as_ref().map(|x| x.as_str()) == Some("r2")));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
