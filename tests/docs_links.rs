//! The docs book and the front pages hold together, offline: every chapter `docs/SUMMARY.md` lists
//! and every `{{#include …}}` exists, and every relative link in README.md, CHANGELOG.md, docs/ and
//! recipes/README.md leads to a file or folder that exists and, with a `#fragment` into Markdown,
//! to a heading of it (ids as GitHub and mdBook make them). Links with a scheme (https:, mailto:)
//! are not fetched: tests reach no network.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The Markdown files checked: the front pages and everything under docs/.
fn pages() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())).flatten().map(|e| e.path()).collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    let r = root();
    let mut out = vec![r.join("README.md"), r.join("CHANGELOG.md"), r.join("recipes/README.md")];
    walk(&r.join("docs"), &mut out);
    out
}

/// A heading's id: lower case, letters, digits, `-` and `_` kept, spaces to `-`, the rest dropped.
fn slug(text: &str) -> String {
    text.trim()
        .chars()
        .filter_map(|c| match c {
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c.to_lowercase().collect::<String>()),
            c if c.is_whitespace() => Some("-".into()),
            _ => None,
        })
        .collect()
}

/// What one page holds: the ids of its headings and its links (destination, line).
struct Page {
    ids: HashSet<String>,
    links: Vec<(String, usize)>,
}

fn read(path: &Path) -> Page {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let line_of = |offset: usize| text[..offset].matches('\n').count() + 1;
    let mut ids = HashSet::new();
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut links = Vec::new();
    let mut heading: Option<String> = None;
    for (event, range) in Parser::new_ext(&text, Options::ENABLE_TABLES | Options::ENABLE_FOOTNOTES | Options::ENABLE_STRIKETHROUGH | Options::ENABLE_TASKLISTS)
        .into_offset_iter()
    {
        match event {
            Event::Start(Tag::Heading { .. }) => heading = Some(String::new()),
            Event::End(TagEnd::Heading(_)) => {
                let base = slug(&heading.take().unwrap_or_default());
                let n = seen.entry(base.clone()).or_insert(0);
                ids.insert(if *n == 0 { base } else { format!("{base}-{n}") });
                *n += 1;
            }
            Event::Text(t) | Event::Code(t) => {
                if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
            }
            Event::Start(Tag::Link { dest_url, .. } | Tag::Image { dest_url, .. }) => links.push((dest_url.to_string(), line_of(range.start))),
            _ => {}
        }
    }
    Page { ids, links }
}

/// What is wrong with `dest` (a link on `page`), if anything.
fn problem(page: &Path, dest: &str, cache: &mut BTreeMap<PathBuf, Page>) -> Option<String> {
    if dest.contains("://") || dest.starts_with("mailto:") {
        return None;
    }
    let (file, fragment) = dest.split_once('#').unwrap_or((dest, ""));
    let target = if file.is_empty() { page.to_path_buf() } else { page.parent().unwrap_or(Path::new(".")).join(file) };
    if !target.exists() {
        return Some(format!("{} does not exist", target.display()));
    }
    if fragment.is_empty() || target.extension().is_none_or(|x| x != "md") {
        return None;
    }
    let key = target.canonicalize().unwrap_or(target.clone());
    let ids = &cache.entry(key).or_insert_with(|| read(&target)).ids;
    (!ids.contains(fragment)).then(|| format!("{} has no heading #{fragment}", target.display()))
}

#[test]
fn every_relative_link_leads_somewhere() {
    let mut cache = BTreeMap::new();
    let mut broken = Vec::new();
    let mut checked = 0;
    for path in pages() {
        for (dest, line) in read(&path).links {
            checked += 1;
            if let Some(p) = problem(&path, &dest, &mut cache) {
                broken.push(format!("{}:{line}: ({dest}) {p}", path.strip_prefix(root()).unwrap_or(&path).display()));
            }
        }
    }
    assert!(checked > 100, "only {checked} links found: is the parser reading the pages?");
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn the_book_lists_only_chapters_that_exist_and_includes_only_files_that_exist() {
    let docs = root().join("docs");
    let summary = read(&docs.join("SUMMARY.md"));
    assert!(summary.links.len() > 10, "SUMMARY.md lists {} chapters", summary.links.len());
    for (dest, line) in &summary.links {
        assert!(docs.join(dest).is_file(), "docs/SUMMARY.md:{line}: chapter {dest} does not exist");
    }
    for page in pages().iter().filter(|p| p.starts_with(&docs)) {
        let text = std::fs::read_to_string(page).unwrap_or_default();
        for (i, line) in text.lines().enumerate() {
            if let Some(rest) = line.split("{{#include ").nth(1) {
                let file = rest.split(['}', ':']).next().unwrap_or("").trim();
                assert!(page.parent().unwrap_or(&docs).join(file).is_file(), "{}:{}: includes {file}, which does not exist", page.display(), i + 1);
            }
        }
    }
}

/// The checks see a broken link and a missing heading (a check that finds nothing finds this).
#[test]
fn a_broken_link_and_a_missing_heading_are_found() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let page = dir.path().join("a.md");
    std::fs::write(&page, "# Top part\n## Top part\n[x](a.md#top-part-1) [y](b.md) [z](#nowhere) [w](https://example.org/x)\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let mut cache = BTreeMap::new();
    let found: Vec<Option<String>> = read(&page).links.iter().map(|(d, _)| problem(&page, d, &mut cache)).collect();
    assert!(found[0].is_none(), "{found:?}");
    assert!(found[1].as_deref().is_some_and(|p| p.contains("does not exist")), "{found:?}");
    assert!(found[2].as_deref().is_some_and(|p| p.contains("#nowhere")), "{found:?}");
    assert!(found[3].is_none(), "{found:?}");
    assert_eq!(slug("The `mrmm op` tool — in short"), "the-mrmm-op-tool--in-short");
}
