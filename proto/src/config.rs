//! Reading config files: JSON5 into typed values, with one-line errors that name the file, the
//! field path and the problem. Library code takes configs as values; only binaries read files.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::ProtoError;

/// Reads a JSON5 file into `T`; errors are one line naming the file, the field path and the problem.
pub fn load_json5<T: DeserializeOwned>(path: &Path) -> Result<T, ProtoError> {
    let text = std::fs::read_to_string(path).map_err(|e| ProtoError::Config(format!("{}: cannot read: {e}", path.display())))?;
    parse_json5(&path.display().to_string(), &text)
}

/// Parses JSON5 text into `T`, naming `origin` and the failing field path in errors.
pub fn parse_json5<T: DeserializeOwned>(origin: &str, text: &str) -> Result<T, ProtoError> {
    let mut de = json5::Deserializer::from_str(text).map_err(|e| ProtoError::Config(format!("{origin}: {}", one_line(&e.to_string()))))?;
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = one_line(&e.inner().to_string());
        if path.is_empty() || path == "." {
            ProtoError::Config(format!("{origin}: {inner}"))
        } else {
            ProtoError::Config(format!("{origin}: {path}: {inner}"))
        }
    })
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Checks that `v` is a finite number in `(0, max]`; the error is `name: problem`.
pub fn positive(name: &str, v: f64, max: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= max {
        Ok(())
    } else {
        Err(format!("{name}: must be a number in (0, {max}] (got {v})"))
    }
}

/// Checks that `v` is a finite number in `[min, max]`; the error is `name: problem`.
pub fn within(name: &str, v: f64, min: f64, max: f64) -> Result<(), String> {
    if v.is_finite() && (min..=max).contains(&v) {
        Ok(())
    } else {
        Err(format!("{name}: must be a number in [{min}, {max}] (got {v})"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct T {
        #[allow(dead_code)]
        a: u32,
    }

    #[test]
    fn errors_are_one_line_with_the_field() {
        let e = parse_json5::<T>("f.json5", "{ a: \"x\" }").expect_err("type");
        assert!(e.to_string().starts_with("f.json5: a: "), "{e}");
        let e = parse_json5::<T>("f.json5", "{ a: ").expect_err("syntax");
        assert!(!e.to_string().contains('\n'));
        let e = load_json5::<T>(Path::new("/nonexistent/x.json5")).expect_err("missing");
        assert!(e.to_string().starts_with("/nonexistent/x.json5: cannot read"));
    }
}
