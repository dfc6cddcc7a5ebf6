//! How many threads a node starts: its own runtime's workers and blocking pool, and Zenoh's
//! runtimes — bounded by role, whatever the number of cores (a robot process on a 16-core
//! computer runs a handful of threads, so one computer can run hundreds of them).

use std::num::NonZeroUsize;

/// Zenoh's runtimes for a robot, unless `ZENOH_RUNTIME` says otherwise: two threads to receive
/// (Zenoh's default: with one, a subscriber whose queue is full holds up every link of the
/// process — docs/zenoh.md), one to send, and the acceptor and network runtimes handed over to
/// the application's (Zenoh's defaults: six threads, and up to 50 blocking threads per runtime).
pub const ROBOT_ZENOH_RUNTIME: &str =
    "(app: (worker_threads: 1, max_blocking_threads: 2), acc: (handover: app), net: (handover: app), tx: (worker_threads: 1, max_blocking_threads: 2), rx: (worker_threads: 2, max_blocking_threads: 2))";

/// A process's threads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Threads {
    /// Async workers of the process's own runtime.
    pub workers: usize,
    /// Its blocking pool at most (file and journal I/O, name lookups).
    pub blocking: usize,
    /// What Zenoh's runtimes are given (`ZENOH_RUNTIME`), if the process sets it.
    pub zenoh: Option<&'static str>,
}

impl Threads {
    /// A robot's (`robot`) or another node's threads; `flag` is `--threads` (`MRMM_THREADS`).
    pub fn new(robot: bool, flag: Option<NonZeroUsize>) -> Threads {
        let cores = std::thread::available_parallelism().map_or(1, NonZeroUsize::get);
        match (robot, flag) {
            (true, flag) => Threads { workers: flag.map_or(2, NonZeroUsize::get), blocking: 4, zenoh: Some(ROBOT_ZENOH_RUNTIME) },
            (false, flag) => Threads { workers: flag.map_or(cores, NonZeroUsize::get), blocking: 64, zenoh: None },
        }
    }

    /// Tells Zenoh its runtimes unless the user did (`ZENOH_RUNTIME` is read when Zenoh first
    /// starts a runtime). Call before any thread is started.
    pub fn configure_zenoh(&self) {
        if let Some(z) = self.zenoh {
            if std::env::var_os("ZENOH_RUNTIME").is_none() {
                std::env::set_var("ZENOH_RUNTIME", z);
            }
        }
    }

    /// The process's runtime (Zenoh needs a multi-thread one).
    pub fn runtime(&self) -> std::io::Result<tokio::runtime::Runtime> {
        tokio::runtime::Builder::new_multi_thread().worker_threads(self.workers).max_blocking_threads(self.blocking).enable_all().build()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_robot_is_small_whatever_the_cores_and_the_flag_sets_the_workers() {
        let r = Threads::new(true, None);
        assert_eq!((r.workers, r.blocking), (2, 4));
        assert_eq!(Threads::new(true, NonZeroUsize::new(1)).workers, 1);
        assert_eq!(Threads::new(false, NonZeroUsize::new(3)).workers, 3);
        assert!(Threads::new(false, None).zenoh.is_none(), "central, routers, the operator: Zenoh's own defaults");
    }

    #[test]
    fn the_robot_runtime_setting_is_one_zenoh_reads() {
        // RON, as Zenoh parses it: every runtime named, no unknown field.
        for rt in ["app", "acc", "net", "tx", "rx"] {
            assert!(ROBOT_ZENOH_RUNTIME.contains(&format!("{rt}: (")), "{rt}");
        }
        assert_eq!(ROBOT_ZENOH_RUNTIME.matches('(').count(), ROBOT_ZENOH_RUNTIME.matches(')').count());
    }
}
