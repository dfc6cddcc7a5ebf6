//! The simulated network: a time-ordered event queue, who can reach whom (nodes up, partition
//! sides), and liveliness tokens as each observer sees them — declared and undeclared at once,
//! lost a lease late through a partition or a false suspicion, seen at once after a crash.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, BinaryHeap};

use mrmm_proto::Time;

/// A liveliness token and who holds it.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Token {
    /// `mrmm/robots/<id>/alive`
    Robot(String),
    /// `mrmm/hosts/<node>/alive`
    Host(String),
    /// `mrmm/planner/*/alive/<central>`
    Planner,
    /// `mrmm/team/<subteam>/member/<robot>`
    Member { subteam: String, robot: String },
}

/// A time-ordered queue of `E` (ties in insertion order).
pub struct Queue<E> {
    heap: BinaryHeap<(Reverse<u64>, Reverse<u64>, usize)>,
    slots: Vec<Option<E>>,
    free: Vec<usize>,
    seq: u64,
}

fn ns(t: Time) -> u64 {
    (t.secs().max(0.0) * 1e9) as u64
}

fn at_ns(t: u64) -> Time {
    Time::from_secs(t as f64 / 1e9)
}

impl<E> Queue<E> {
    pub fn new() -> Self {
        Queue { heap: BinaryHeap::new(), slots: Vec::new(), free: Vec::new(), seq: 0 }
    }

    pub fn push(&mut self, at: Time, e: E) {
        self.seq += 1;
        let i = match self.free.pop() {
            Some(i) => {
                self.slots[i] = Some(e);
                i
            }
            None => {
                self.slots.push(Some(e));
                self.slots.len() - 1
            }
        };
        self.heap.push((Reverse(ns(at)), Reverse(self.seq), i));
    }

    /// The next event and its time.
    pub fn pop(&mut self) -> Option<(Time, E)> {
        let (Reverse(t), _, i) = self.heap.pop()?;
        let e = self.slots[i].take()?;
        self.free.push(i);
        Some((at_ns(t), e))
    }

    pub fn peek_time(&self) -> Option<Time> {
        self.heap.peek().map(|(Reverse(t), _, _)| at_ns(*t))
    }
}

/// Who can reach whom.
#[derive(Debug, Clone)]
pub struct Links {
    pub up: Vec<bool>,
    /// Each node's process incarnation (grows with every restart).
    pub inc: Vec<u32>,
    side: Vec<bool>,
    partitioned: bool,
    /// (observer, subject) pairs where the observer falsely lost the subject's liveliness.
    suspected: BTreeSet<(usize, usize)>,
}

impl Links {
    pub fn new(n: usize) -> Links {
        Links { up: vec![true; n], inc: vec![0; n], side: vec![false; n], partitioned: false, suspected: BTreeSet::new() }
    }

    /// Whether a message from `a` reaches `b` now.
    pub fn connected(&self, a: usize, b: usize) -> bool {
        self.up[a] && self.up[b] && (!self.partitioned || self.side[a] == self.side[b])
    }

    /// Whether `observer` sees `subject`'s tokens (connected and not suspected).
    pub fn sees(&self, observer: usize, subject: usize) -> bool {
        self.connected(observer, subject) && !self.suspected.contains(&(observer, subject))
    }

    pub fn partition(&mut self, side: Vec<bool>) {
        self.side = side;
        self.partitioned = true;
    }
    pub fn heal(&mut self) {
        self.partitioned = false;
    }
    pub fn partitioned(&self) -> bool {
        self.partitioned
    }
    /// The side of the last partition `node` is on.
    pub fn side_of(&self, node: usize) -> bool {
        self.side.get(node).copied().unwrap_or(false)
    }
    pub fn suspect(&mut self, observer: usize, subject: usize, on: bool) {
        if on {
            self.suspected.insert((observer, subject));
        } else {
            self.suspected.remove(&(observer, subject));
        }
    }
}

/// What each observer was last told of each token, and when the next change may arrive (changes
/// to one observer about one token arrive in order).
#[derive(Debug, Default)]
pub struct Beliefs {
    seen: BTreeMap<(usize, Token), bool>,
    next: BTreeMap<(usize, Token), Time>,
}

/// A liveliness change to deliver.
#[derive(Debug, Clone)]
pub struct Change {
    pub at: Time,
    pub observer: usize,
    pub token: Token,
    pub up: bool,
}

impl Beliefs {
    /// Forgets what `observer` was told (it restarted, or changed what it watches); tokens
    /// `keep` says are still watched are kept.
    pub fn forget(&mut self, observer: usize, keep: impl Fn(&Token) -> bool) {
        self.seen.retain(|(o, t), _| *o != observer || keep(t));
        self.next.retain(|(o, t), _| *o != observer || keep(t));
    }

    /// The tokens `observer` holds up (what its Zenoh tables hold: changes scheduled for it
    /// included).
    pub fn up_for(&self, observer: usize) -> impl Iterator<Item = &Token> {
        self.seen.iter().filter(move |((o, _), up)| *o == observer && **up).map(|((_, t), _)| t)
    }

    /// The changes to deliver so that every live observer ends up seeing what it watches
    /// (`watches`) of the `present` tokens (token, holder) it can see now, each `delay` from `now`.
    pub fn update(&mut self, now: Time, delay: f64, links: &Links, present: &[(Token, usize)], watches: impl Fn(usize, &Token) -> bool) -> Vec<Change> {
        let mut out = Vec::new();
        for observer in 0..links.up.len() {
            if !links.up[observer] {
                continue;
            }
            let mut candidates: BTreeMap<Token, bool> = BTreeMap::new();
            for (t, holder) in present {
                if watches(observer, t) {
                    let up = links.sees(observer, *holder);
                    let e = candidates.entry(t.clone()).or_insert(false);
                    *e |= up;
                }
            }
            for ((o, t), up) in &self.seen {
                if *o == observer && *up && watches(observer, t) {
                    candidates.entry(t.clone()).or_insert(false);
                }
            }
            for (t, up) in candidates {
                let key = (observer, t);
                if self.seen.get(&key).copied().unwrap_or(false) == up {
                    continue;
                }
                self.seen.insert(key.clone(), up);
                let at = (now + delay).max(self.next.get(&key).copied().unwrap_or(Time::ZERO) + 1e-6);
                self.next.insert(key.clone(), at);
                out.push(Change { at, observer, token: key.1, up });
            }
        }
        out
    }
}
