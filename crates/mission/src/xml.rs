//! A small XML element tree (read with `quick-xml`) and an indenting
//! writer: what the WPML and KML files of this crate need, no more. Names
//! keep their prefix (`wpml:index`), as DJI writes them: a file that binds
//! the WPML namespace to another prefix is not one DJI Pilot reads either.

use std::fmt::Write as _;

use quick_xml::events::Event;
use quick_xml::Reader;

/// One element: its qualified name, attributes, text and children.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Element {
    /// Qualified name (`wpml:index`, `Placemark`).
    pub name: String,
    /// Attributes in document order (name, value).
    pub attributes: Vec<(String, String)>,
    /// The element's own text, trimmed.
    pub text: String,
    /// Child elements in document order.
    pub children: Vec<Element>,
}

impl Element {
    /// The first child named `name`.
    pub fn child(&self, name: &str) -> Option<&Element> {
        self.children.iter().find(|c| c.name == name)
    }

    /// Every child named `name`.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> {
        self.children.iter().filter(move |c| c.name == name)
    }

    /// The text of the child at `path` (names separated by `/`).
    pub fn text_at(&self, path: &str) -> Option<&str> {
        let mut e = self;
        for part in path.split('/') {
            e = e.child(part)?;
        }
        Some(e.text.as_str())
    }

    /// The value of attribute `name`.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// Every element below this one (depth first), this one included.
    pub fn descendants(&self) -> Vec<&Element> {
        let mut out = vec![self];
        let mut i = 0;
        while i < out.len() {
            let e = out[i];
            out.extend(e.children.iter());
            i += 1;
        }
        out
    }
}

/// Parses `text` into its root element; the error says where it stopped.
pub fn parse(text: &str) -> std::result::Result<Element, String> {
    let mut reader = Reader::from_str(text);
    let mut stack: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    loop {
        let pos = reader.buffer_position();
        let event = reader
            .read_event()
            .map_err(|e| format!("byte {pos}: not well-formed XML: {e}"))?;
        match event {
            Event::Start(_) | Event::Empty(_) if root.is_some() => {
                return Err(format!("byte {pos}: content after the root element"));
            }
            Event::Start(s) => stack.push(start_element(&s, pos)?),
            Event::Empty(s) => {
                let e = start_element(&s, pos)?;
                close(&mut stack, &mut root, e);
            }
            Event::End(_) => {
                let e = stack
                    .pop()
                    .ok_or_else(|| format!("byte {pos}: end tag without a start"))?;
                let mut e = e;
                e.text = e.text.trim().to_string();
                close(&mut stack, &mut root, e);
            }
            Event::Text(t) => {
                if let Some(top) = stack.last_mut() {
                    let s = t
                        .decode()
                        .map_err(|e| format!("byte {pos}: text is not UTF-8: {e}"))?;
                    top.text.push_str(&s);
                }
            }
            Event::CData(t) => {
                if let Some(top) = stack.last_mut() {
                    top.text.push_str(&String::from_utf8_lossy(&t));
                }
            }
            Event::GeneralRef(r) => {
                if let Some(top) = stack.last_mut() {
                    let c = match r.resolve_char_ref() {
                        Ok(Some(c)) => c,
                        _ => match r.decode().as_deref() {
                            Ok("amp") => '&',
                            Ok("lt") => '<',
                            Ok("gt") => '>',
                            Ok("quot") => '"',
                            Ok("apos") => '\'',
                            _ => return Err(format!("byte {pos}: unknown entity reference")),
                        },
                    };
                    top.text.push(c);
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if !stack.is_empty() {
        return Err(format!("the element <{}> is never closed", stack[0].name));
    }
    root.ok_or_else(|| "no root element".to_string())
}

fn start_element(
    s: &quick_xml::events::BytesStart<'_>,
    pos: u64,
) -> std::result::Result<Element, String> {
    let name = String::from_utf8_lossy(s.name().as_ref()).into_owned();
    let mut attributes = Vec::new();
    for a in s.attributes() {
        let a = a.map_err(|e| format!("byte {pos}: bad attribute in <{name}>: {e}"))?;
        attributes.push((
            String::from_utf8_lossy(a.key.as_ref()).into_owned(),
            String::from_utf8_lossy(&a.value).into_owned(),
        ));
    }
    Ok(Element {
        name,
        attributes,
        ..Element::default()
    })
}

fn close(stack: &mut [Element], root: &mut Option<Element>, e: Element) {
    match stack.last_mut() {
        Some(parent) => parent.children.push(e),
        None => *root = Some(e),
    }
}

/// Escapes `&`, `<`, `>` and `"` for text and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            c => out.push(c),
        }
    }
    out
}

/// A number as DJI writes them: up to `decimals` decimals, trailing zeros
/// dropped, never an exponent (`-0` is written `0`).
pub fn num(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

/// An indenting XML writer (two spaces, as DJI's files).
#[derive(Debug, Default)]
pub struct Writer {
    out: String,
    open: Vec<String>,
}

impl Writer {
    /// A document starting with the UTF-8 declaration.
    pub fn document() -> Writer {
        Writer {
            out: "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n".into(),
            open: Vec::new(),
        }
    }

    fn indent(&mut self) {
        for _ in 0..self.open.len() {
            self.out.push_str("  ");
        }
    }

    /// Opens `<tag attrs...>`.
    pub fn open(&mut self, tag: &str, attrs: &[(&str, &str)]) {
        self.indent();
        let _ = write!(self.out, "<{tag}");
        for (k, v) in attrs {
            let _ = write!(self.out, " {k}=\"{}\"", escape(v));
        }
        self.out.push_str(">\n");
        self.open.push(tag.to_string());
    }

    /// Closes the innermost open element.
    pub fn close(&mut self) {
        if let Some(tag) = self.open.pop() {
            self.indent();
            let _ = writeln!(self.out, "</{tag}>");
        }
    }

    /// `<tag>value</tag>` on one line.
    pub fn leaf(&mut self, tag: &str, value: impl std::fmt::Display) {
        self.indent();
        let _ = writeln!(self.out, "<{tag}>{}</{tag}>", escape(&value.to_string()));
    }

    /// The text, every open element closed.
    pub fn finish(mut self) -> String {
        while !self.open.is_empty() {
            self.close();
        }
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_text_reads_back() {
        let mut w = Writer::document();
        w.open("kml", &[("xmlns:wpml", "http://www.dji.com/wpmz/1.0.6")]);
        w.leaf("wpml:author", "a & <b>");
        w.leaf("wpml:height", num(-0.000_000_1, 3));
        let doc = parse(&w.finish()).unwrap();
        assert_eq!(doc.name, "kml");
        assert_eq!(
            doc.attribute("xmlns:wpml"),
            Some("http://www.dji.com/wpmz/1.0.6")
        );
        assert_eq!(doc.text_at("wpml:author"), Some("a & <b>"));
        assert_eq!(doc.text_at("wpml:height"), Some("0"));
        assert!(parse("<a><b></a>").is_err());
        assert!(parse("").is_err());
    }
}
