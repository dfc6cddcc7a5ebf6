//! The machinery behind `declare_keys!` in [`super`]: the macros that generate `Display` and
//! `Key::parse` from each key's declaration, the fields a chunk can be, and the matcher of a
//! key's chunks against a declaration.

use super::{validate_id, validate_subteam, validate_team_path, SystemCmd};

/// Generates `Display` and [`Key::parse`] for [`Key`] from one table of declarations.
macro_rules! declare_keys {
    ($( $variant:ident $(($tuple:ident))? $({ $($field:ident),+ })? => $($chunk:tt)/+ ; )*) => {
        impl fmt::Display for Key {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match self {
                    $( Key::$variant $(($tuple))? $({ $($field),+ })? => {
                        let mut sep = "";
                        $( key_chunk!(f, sep, $chunk); )+
                        let _ = sep;
                        Ok(())
                    } )*
                }
            }
        }

        impl Key {
            /// Parses a concrete key; `None` for anything that is not exactly one of ours
            /// (wildcards, extra chunks, bad ids).
            pub fn parse(key: &str) -> Option<Key> {
                let parts: Vec<&str> = key.split('/').collect();
                $(
                    let template = [$( key_part!($chunk) ),+];
                    if let Some(caps) = captures(&template, &parts) {
                        // A closure for `?` on each field: the first field that does not check
                        // makes this declaration not the key's.
                        #[allow(clippy::redundant_closure_call)]
                        let built = (|| {
                            #[allow(unused_mut, unused_variables)]
                            let mut caps = caps.into_iter();
                            $( key_bind!(caps, $chunk); )+
                            Some(Key::$variant $(($tuple))? $({ $($field),+ })?)
                        })();
                        if built.is_some() {
                            return built;
                        }
                    }
                )*
                None
            }
        }
    };
}

/// One chunk of a key, written.
macro_rules! key_chunk {
    ($f:ident, $sep:ident, $lit:literal) => {
        $f.write_str($sep)?;
        $f.write_str($lit)?;
        $sep = "/";
    };
    ($f:ident, $sep:ident, { $x:ident : $kind:ident }) => {
        $f.write_str($sep)?;
        write!($f, "{}", $x)?;
        $sep = "/";
    };
}

/// One chunk of a key's template.
macro_rules! key_part {
    ($lit:literal) => {
        Part::Lit($lit)
    };
    ({ $x:ident : team }) => {
        Part::Many
    };
    ({ $x:ident : subteam }) => {
        Part::Many
    };
    ({ $x:ident : cmd }) => {
        Part::Many
    };
    ({ $x:ident : $kind:ident }) => {
        Part::One
    };
}

/// The field a chunk of a key binds, parsed and checked by its kind.
macro_rules! key_bind {
    ($caps:ident, $lit:literal) => {};
    ($caps:ident, { $x:ident : $kind:ident }) => {
        let $x = $kind($caps.next()?)?;
    };
}

/// One id chunk, checked.
pub(super) fn id<T: From<String>>(s: &[&str]) -> Option<T> {
    let [s] = s else { return None };
    validate_id(s).ok().map(|_| T::from(s.to_string()))
}

/// A decimal chunk without sign or leading `+`.
pub(super) fn num(s: &[&str]) -> Option<u32> {
    let [s] = s else { return None };
    (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())).then(|| s.parse().ok()).flatten()
}

/// A map bundle's hash chunk.
pub(super) fn hash(s: &[&str]) -> Option<String> {
    let [s] = s else { return None };
    super::is_hash(s).then(|| s.to_string())
}

/// A team path from key chunks, checked.
pub(super) fn team(chunks: &[&str]) -> Option<String> {
    let path = chunks.join("/");
    validate_team_path(&path).ok().map(|_| path)
}

/// A sub-team (`<team path>/<type>`) from key chunks, checked.
pub(super) fn subteam(chunks: &[&str]) -> Option<String> {
    let path = chunks.join("/");
    validate_subteam(&path).ok().map(|_| path)
}

/// An operator command from its chunks.
pub(super) fn cmd(chunks: &[&str]) -> Option<SystemCmd> {
    SystemCmd::parse(chunks)
}

/// One chunk of a key's declaration.
#[derive(Debug, Clone, Copy)]
pub(super) enum Part {
    Lit(&'static str),
    /// A field of one chunk.
    One,
    /// A field of one chunk or more (at most one per key).
    Many,
}

/// The chunks of `key` each field of `template` takes, in order; `None` if the key does not have
/// the template's shape.
pub(super) fn captures<'k, 'a>(template: &[Part], key: &'k [&'a str]) -> Option<Vec<&'k [&'a str]>> {
    let many = template.iter().any(|p| matches!(p, Part::Many));
    let wide = key.len().checked_sub(template.len() - 1)?;
    if (!many && key.len() != template.len()) || (many && wide == 0) {
        return None;
    }
    // Each part's chunks; every key is parsed against the declarations in turn, so the literals
    // are checked before anything is collected (most declarations fail there, allocating nothing).
    let spans = template.iter().scan(0, |at, p| {
        let n = if matches!(p, Part::Many) { wide } else { 1 };
        *at += n;
        Some((p, *at - n..*at))
    });
    if !spans.clone().all(|(p, r)| !matches!(p, Part::Lit(l) if key.get(r.start) != Some(l))) {
        return None;
    }
    spans.filter(|(p, _)| !matches!(p, Part::Lit(_))).map(|(_, r)| key.get(r)).collect()
}
