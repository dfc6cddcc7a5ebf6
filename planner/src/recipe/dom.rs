//! A minimal XML element tree with source positions, read with quick-xml, so that every later
//! error can name line:column.

use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

use crate::error::PlanError;

/// Line and column (1-based) of an element's `<`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Pos {
    pub line: usize,
    pub column: usize,
}

impl Pos {
    pub fn err(self, msg: impl Into<String>) -> PlanError {
        PlanError::Recipe { line: self.line, column: self.column, msg: msg.into() }
    }
}

/// An element: name, attributes in order, children, text content.
#[derive(Debug, Clone, PartialEq)]
pub struct Element {
    pub name: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub text: String,
    pub pos: Pos,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    /// Errors on any attribute not in `allowed`.
    pub fn only_attrs(&self, allowed: &[&str]) -> Result<(), PlanError> {
        match self.attrs.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
            Some((k, _)) => Err(self.pos.err(format!(
                "unknown attribute `{k}` on <{}> (expected: {})",
                self.name,
                if allowed.is_empty() { "none".to_string() } else { allowed.join(", ") }
            ))),
            None => Ok(()),
        }
    }

    pub fn required(&self, name: &str) -> Result<&str, PlanError> {
        self.attr(name).ok_or_else(|| self.pos.err(format!("<{}> needs attribute `{name}`", self.name)))
    }

    /// A required finite number attribute.
    pub fn number(&self, name: &str) -> Result<f64, PlanError> {
        let v = self.required(name)?;
        v.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| self.pos.err(format!("<{}> attribute `{name}`: {v:?} is not a finite number", self.name)))
    }

    /// Errors if the element has text content.
    pub fn no_text(&self) -> Result<(), PlanError> {
        if self.text.trim().is_empty() {
            Ok(())
        } else {
            Err(self.pos.err(format!("<{}> takes no text", self.name)))
        }
    }
}

/// Line and column of byte offsets in `src`, counted incrementally: positions are asked for in
/// increasing order while parsing, so the whole document is scanned once (an earlier offset, for
/// an error, is counted from the start).
struct Lines<'a> {
    src: &'a str,
    /// The last offset counted, its line, and where that line starts.
    at: usize,
    line: usize,
    line_start: usize,
}

impl<'a> Lines<'a> {
    fn new(src: &'a str) -> Self {
        Lines { src, at: 0, line: 1, line_start: 0 }
    }

    fn pos(&mut self, offset: usize) -> Pos {
        let offset = offset.min(self.src.len());
        if offset < self.at {
            *self = Lines::new(self.src);
        }
        let bytes = self.src.as_bytes();
        for (i, &b) in bytes[self.at..offset].iter().enumerate() {
            if b == b'\n' {
                self.line += 1;
                self.line_start = self.at + i + 1;
            }
        }
        self.at = offset;
        let column = String::from_utf8_lossy(&bytes[self.line_start..offset]).chars().count() + 1;
        Pos { line: self.line, column }
    }

    /// Position of the next `<` at or after `from`.
    fn tag(&mut self, from: usize) -> Pos {
        // Bytes, not str: `from` may fall inside a multi-byte character (a BOM, say).
        let from = from.min(self.src.len());
        let at = self.src.as_bytes()[from..].iter().position(|&b| b == b'<').map_or(from, |i| from + i);
        self.pos(at)
    }
}

fn start(e: &BytesStart, pos: Pos) -> Result<Element, PlanError> {
    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let mut attrs = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| pos.err(format!("bad attribute on <{name}>: {err}")))?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value = a.unescape_value().map_err(|err| pos.err(format!("attribute `{key}`: {err}")))?.into_owned();
        if attrs.iter().any(|(k, _)| k == &key) {
            return Err(pos.err(format!("attribute `{key}` given twice on <{name}>")));
        }
        attrs.push((key, value));
    }
    Ok(Element { name, attrs, children: Vec::new(), text: String::new(), pos })
}

/// Parses a whole document into its root element: at most
/// [`MAX_RECIPE_DEPTH`](crate::limits::MAX_RECIPE_DEPTH) levels deep and
/// [`MAX_RECIPE_ELEMENTS`](crate::limits::MAX_RECIPE_ELEMENTS) elements.
pub fn parse(src: &str) -> Result<Element, PlanError> {
    use crate::limits::{MAX_RECIPE_DEPTH, MAX_RECIPE_ELEMENTS};
    let mut reader = Reader::from_str(src);
    reader.config_mut().trim_text(true);
    let mut lines = Lines::new(src);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let mut elements = 0usize;
    loop {
        let before = reader.buffer_position() as usize;
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                let p = lines.pos(reader.error_position() as usize);
                return Err(p.err(format!("malformed XML: {e}")));
            }
        };
        match event {
            Event::Start(e) | Event::Empty(e) if elements >= MAX_RECIPE_ELEMENTS => {
                let _ = e;
                return Err(lines.tag(before).err(format!("more than {MAX_RECIPE_ELEMENTS} elements")));
            }
            Event::Start(e) => {
                elements += 1;
                if stack.len() >= MAX_RECIPE_DEPTH {
                    return Err(lines.tag(before).err(format!("elements nested deeper than {MAX_RECIPE_DEPTH} levels")));
                }
                let el = start(&e, lines.tag(before))?;
                stack.push(el);
            }
            Event::Empty(e) => {
                elements += 1;
                let el = start(&e, lines.tag(before))?;
                attach(&mut stack, &mut root, el, &mut lines, before)?;
            }
            Event::End(_) => {
                let el = stack.pop().ok_or_else(|| lines.tag(before).err("closing tag without opening tag"))?;
                attach(&mut stack, &mut root, el, &mut lines, before)?;
            }
            Event::Text(t) => {
                let text = t.unescape().map_err(|e| lines.tag(before).err(format!("bad text: {e}")))?;
                match stack.last_mut() {
                    Some(el) => el.text.push_str(&text),
                    None if text.trim().is_empty() => {}
                    None => return Err(lines.pos(before).err("text outside the root element")),
                }
            }
            Event::CData(t) => {
                if let Some(el) = stack.last_mut() {
                    el.text.push_str(&String::from_utf8_lossy(&t));
                }
            }
            Event::Eof => break,
            // Declarations, comments, processing instructions, doctype.
            _ => {}
        }
    }
    if let Some(open) = stack.last() {
        return Err(open.pos.err(format!("<{}> is never closed", open.name)));
    }
    root.ok_or_else(|| Pos { line: 1, column: 1 }.err("empty document: no root element"))
}

fn attach(stack: &mut [Element], root: &mut Option<Element>, el: Element, lines: &mut Lines<'_>, at: usize) -> Result<(), PlanError> {
    match stack.last_mut() {
        Some(parent) => parent.children.push(el),
        None if root.is_none() => *root = Some(el),
        None => return Err(lines.tag(at).err("more than one root element")),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_position_inside_a_multibyte_character_does_not_panic() {
        // Found by the recipe fuzz target: a byte offset inside a BOM sliced a str.
        for text in ["\u{feff}\u{b}<<?xml version=\"0.0\"?>\n<a/>", "\u{feff}\u{feff}</x>", "\u{feff}<a>\u{feff}</b>"] {
            let e = parse(text).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.starts_with("1:"), "{text:?}: {e}");
        }
    }

    #[test]
    fn positions_and_structure() {
        let doc = parse("<?xml version=\"1.0\"?>\n<a x=\"1\">\n  <b/>\n  <c>hi &amp; bye</c>\n</a>\n").expect("parse");
        assert_eq!(doc.name, "a");
        assert_eq!(doc.pos, Pos { line: 2, column: 1 });
        assert_eq!(doc.children[0].pos, Pos { line: 3, column: 3 });
        assert_eq!(doc.children[1].text, "hi & bye");
        assert_eq!(doc.attr("x"), Some("1"));
    }

    #[test]
    fn malformed_documents() {
        let e = parse("<a>\n  <b>\n</a>").unwrap_err().to_string();
        assert!(e.starts_with("3:"), "{e}");
        assert!(parse("").unwrap_err().to_string().contains("no root"));
        assert!(parse("<a/><b/>").unwrap_err().to_string().contains("more than one root"));
        assert!(parse("<a x=\"1\" x=\"2\"/>").is_err());
        assert!(parse("<a>\n<b>").unwrap_err().to_string().contains("never closed"));
    }

    #[test]
    fn deep_or_huge_documents_are_refused_quickly_with_a_position() {
        // 200 000 levels deep (the old parser took minutes and would recurse on drop).
        let deep = format!("{}{}", "<a>".repeat(200_000), "</a>".repeat(200_000));
        let t = std::time::Instant::now();
        let e = parse(&deep).unwrap_err().to_string();
        assert!(e.starts_with("1:97: ") && e.contains("deeper than 32"), "{e}");
        assert!(t.elapsed().as_secs_f64() < 5.0, "refused at once, not after a scan per element");
        let wide = format!("<r>{}</r>", "<a/>".repeat(20_000));
        assert!(parse(&wide).unwrap_err().to_string().contains("more than 10000 elements"));
        // Positions of a long document are right.
        let long = format!("<r>\n{}<bad x=1/></r>", "<a/>\n".repeat(5000));
        let e = parse(&long).unwrap_err().to_string();
        assert!(e.starts_with("5002:"), "{e}");
    }
}
