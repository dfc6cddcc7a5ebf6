//! Every key expression is declared once, in `proto/src/keys/`: no other Rust file of the
//! workspace spells a string literal starting with `mrmm/`.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if p.is_dir() {
            if !name.starts_with('.') && name != "target" {
                rust_files(&p, out);
            }
        } else if name.ends_with(".rs") {
            out.push(p);
        }
    }
}

#[test]
fn no_key_literal_outside_the_protocol_crate() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(root, &mut files);
    assert!(files.len() > 50, "the walk found the workspace ({} files)", files.len());
    let keys = root.join("proto/src/keys");
    let this = root.join("tests/keys_declared_once.rs");
    let needle = ['"', 'm', 'r', 'm', 'm', '/'].iter().collect::<String>();
    let mut offenders = Vec::new();
    for f in files.iter().filter(|f| !f.starts_with(&keys) && **f != this) {
        let text = std::fs::read_to_string(f).unwrap_or_default();
        for (i, line) in text.lines().enumerate() {
            if line.contains(&needle) {
                offenders.push(format!("{}:{}: {}", f.strip_prefix(root).unwrap_or(f).display(), i + 1, line.trim()));
            }
        }
    }
    assert!(offenders.is_empty(), "key literals outside proto/src/keys/:\n{}", offenders.join("\n"));
    // The check sees a literal where there is one.
    let keys_text = std::fs::read_to_string(keys.join("pattern.rs")).unwrap_or_default();
    assert!(keys_text.contains(&needle), "the needle is found in keys/pattern.rs");
}
