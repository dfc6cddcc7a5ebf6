//! Which keys a key expression takes in, as a Zenoh subscription or queryable would: `*` is one
//! chunk, `**` any number of chunks (none included). The simulations route what a node publishes
//! by the subscriptions its machines declare, with this; the drivers hand the same expressions
//! to Zenoh. Only what mrmm's own patterns use (no `$*` inside a chunk).

/// Whether `pattern` takes in the concrete key `key`.
pub fn includes(pattern: &str, key: &str) -> bool {
    let p: Vec<&str> = pattern.split('/').collect();
    let k: Vec<&str> = key.split('/').collect();
    chunks(&p, &k)
}

fn chunks(p: &[&str], k: &[&str]) -> bool {
    match p.split_first() {
        None => k.is_empty(),
        // `**` takes none, or one more chunk and stays: each chunk of the key is tried at most
        // once per `**`, so the work is bounded by |p| × |k|.
        Some((&"**", rest)) => (0..=k.len()).any(|skip| chunks(rest, &k[skip..])),
        Some((&first, rest)) => match k.split_first() {
            Some((&chunk, krest)) => (first == "*" || first == chunk) && chunks(rest, krest),
            None => false,
        },
    }
}

/// One subscription of a machine: a key expression, and whether it takes in its own node's
/// publications (Zenoh's `allowed_origin`: a robot does not hear its own arrivals).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Sub {
    pub expr: String,
    pub remote_only: bool,
}

impl Sub {
    /// What `expr` takes in, from anywhere.
    pub fn any(expr: impl ToString) -> Sub {
        Sub { expr: expr.to_string(), remote_only: false }
    }

    /// What `expr` takes in, from other nodes only.
    pub fn remote(expr: impl ToString) -> Sub {
        Sub { expr: expr.to_string(), remote_only: true }
    }

    /// Whether a publication on `key` reaches this subscription (`local`: from its own node).
    pub fn takes(&self, key: &str, local: bool) -> bool {
        !(local && self.remote_only) && includes(&self.expr, key)
    }
}

/// Whether any of `subs` takes in a publication on `key`.
pub fn heard(subs: &[Sub], key: &str, local: bool) -> bool {
    subs.iter().any(|s| s.takes(key, local))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use zenoh::key_expr::KeyExpr;

    fn zenoh_includes(p: &str, k: &str) -> bool {
        // Zenoh's canonical form (`**/*` is written `*/**`); the same set of keys.
        let p = KeyExpr::autocanonize(p.to_string()).expect("pattern");
        let k = KeyExpr::try_from(k).expect("key");
        p.includes(&k)
    }

    #[test]
    fn wildcards_take_in_what_zenoh_takes_in() {
        for (p, k, want) in [
            ("fleet/robots/*/alive", "fleet/robots/r1/alive", true),
            ("fleet/robots/*/alive", "fleet/robots/r1/telemetry", false),
            ("fleet/team/p/**/member/*", "fleet/team/p/member/r1", true),
            ("fleet/team/p/**/member/*", "fleet/team/p/air/north/member/r1", true),
            ("fleet/team/p/**/member/*", "fleet/team/q/member/r1", false),
            ("fleet/**", "fleet/system/cmd/create", true),
            ("fleet/team/p/sync/*/*", "fleet/team/p/air/sync/0/0", false),
        ] {
            assert_eq!(includes(p, k), want, "{p} {k}");
            assert_eq!(zenoh_includes(p, k), want, "{p} {k}");
        }
    }

    fn chunk() -> impl Strategy<Value = &'static str> {
        prop::sample::select(vec!["a", "b", "mrmm", "sync"])
    }

    proptest! {
        /// On random patterns of mrmm's alphabet and random keys, ours agrees with Zenoh's.
        #[test]
        fn agrees_with_zenoh(
            p in prop::collection::vec(prop::sample::select(vec!["a", "b", "mrmm", "sync", "*", "**"]), 1..7),
            k in prop::collection::vec(chunk(), 1..8),
        ) {
            // Zenoh writes `**/**` as one `**`; a pattern of mrmm's never has two in a row.
            prop_assume!(!p.windows(2).any(|w| w == ["**", "**"]));
            let (p, k) = (p.join("/"), k.join("/"));
            prop_assert_eq!(includes(&p, &k), zenoh_includes(&p, &k), "{} {}", p, k);
        }
    }
}
