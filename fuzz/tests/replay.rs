//! Every fuzz target's body on its committed seeds (`fuzz/seeds/<target>/`) and on mutations of
//! them, on the stable toolchain: what `cargo test` keeps of the fuzzing between real campaigns
//! (`fuzz/run.sh`, nightly + cargo-fuzz). The mutations are libFuzzer's simplest (bytes flipped,
//! set, inserted, erased, copied, frames spliced from another seed), drawn from a fixed seed so a
//! failure replays; no coverage guides them. An input that panics is written to
//! `fuzz/artifacts/<target>/` and named in the failure, ready to become a seed.

use std::path::{Path, PathBuf};

use mrmm_fuzz::targets;

/// Mutants tried per seed; `MRMM_FUZZ_MUTANTS` asks for more.
const MUTANTS: u64 = 2000;

/// A small deterministic generator (xorshift64*), enough to pick mutations.
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A number below `n` (0 when `n` is 0).
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            usize::try_from(self.next() % n as u64).unwrap_or(0)
        }
    }
}

/// Bytes that matter to the decoders: the frame separator, JSON's punctuation, digits, extremes.
const INTERESTING: &[u8] = b"\0\x01\x7f\x80\xff\"{}[]:,-.0123456789eE\\ntf";

/// One mutation of `input`, `other` a second seed of the same target to splice from.
fn mutate(d: &mut Draw, input: &mut Vec<u8>, other: &[u8]) {
    let len = input.len();
    match d.below(7) {
        0 if len > 0 => {
            let i = d.below(len);
            input[i] ^= 1 << d.below(8);
        }
        1 if len > 0 => {
            let i = d.below(len);
            input[i] = INTERESTING[d.below(INTERESTING.len())];
        }
        2 => {
            let at = d.below(len + 1);
            let b = INTERESTING[d.below(INTERESTING.len())];
            input.splice(at..at, std::iter::repeat_n(b, 1 + d.below(4)));
        }
        3 if len > 0 => {
            let at = d.below(len);
            let n = 1 + d.below((len - at).min(64));
            input.drain(at..at + n);
        }
        4 if len > 0 => {
            let from = d.below(len);
            let n = 1 + d.below((len - from).min(256));
            let chunk = input[from..from + n].to_vec();
            let at = d.below(len + 1);
            input.splice(at..at, chunk);
        }
        5 if !other.is_empty() => {
            let from = d.below(other.len());
            let n = 1 + d.below((other.len() - from).min(512));
            let at = d.below(len + 1);
            input.splice(at..at, [0].into_iter().chain(other[from..from + n].iter().copied()));
        }
        _ => input.truncate(d.below(len + 1)),
    }
}

fn seeds(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("seeds").join(target);
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| {
            let path = entry.unwrap_or_else(|e| panic!("{}: {e}", dir.display())).path();
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            (path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(), bytes)
        })
        .collect();
    out.sort();
    assert!(!out.is_empty(), "{}: no seeds", dir.display());
    out
}

/// Runs `body` on `input`; a panic writes the input out and fails with where it is.
fn run(target: &str, name: &str, input: &[u8], body: fn(&[u8])) {
    if std::panic::catch_unwind(|| body(input)).is_err() {
        let dir: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("artifacts").join(target);
        let path = dir.join(format!("crash-replay-{name}"));
        let saved = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, input));
        panic!("fuzz target {target} panicked on {name} ({} bytes; written to {}: {saved:?})", input.len(), path.display());
    }
}

/// The seeds of `target`, then `MUTANTS` mutants of each (one to four mutations apiece).
fn replay(target: &str, body: fn(&[u8])) {
    let mutants = std::env::var("MRMM_FUZZ_MUTANTS").ok().and_then(|v| v.parse().ok()).unwrap_or(MUTANTS);
    let seeds = seeds(target);
    for (k, (name, seed)) in seeds.iter().enumerate() {
        run(target, name, seed, body);
        let other = &seeds[(k + 1) % seeds.len()].1;
        let mut d = Draw(0x9e37_79b9_7f4a_7c15 ^ (k as u64 + 1).wrapping_mul(0x1000_0000_01b3));
        for m in 0..mutants {
            let mut input = seed.clone();
            for _ in 0..=d.below(4) {
                mutate(&mut d, &mut input, other);
            }
            run(target, &format!("{name}-mutant-{m}"), &input, body);
        }
    }
}

#[test]
fn recipe() {
    replay("recipe", targets::recipe::run);
}

#[test]
fn central() {
    replay("central", targets::central::run);
}

#[test]
fn host() {
    replay("host", targets::host::run);
}

#[test]
fn robot() {
    replay("robot", targets::robot::run);
}

#[test]
fn seal() {
    replay("seal", targets::seal::run);
}

#[test]
fn ros2() {
    replay("ros2", targets::ros2::run);
}

/// The mutations change inputs (a replay that only ran the seeds would pass this file unseen).
#[test]
fn mutants_differ_from_their_seed() {
    let seed = b"\x07{\"a\":1}\0\x0f".to_vec();
    let mut d = Draw(7);
    let changed = (0..100)
        .filter(|_| {
            let mut input = seed.clone();
            mutate(&mut d, &mut input, b"xyz");
            input != seed
        })
        .count();
    assert!(changed > 80, "{changed} of 100 mutations changed the input");
}
