//! The document layer of the Mitsuba reader: XML text → a tree of owned elements ([`El`]),
//! with `include`s spliced in, `<default>`s recorded and every `$name` in an attribute
//! substituted, in document order (as Mitsuba does). Each element keeps its byte span in the
//! concatenation of all the files read, so that [`super::super::spanned::Cx`] names the right
//! file and line for it later; errors found here (malformed XML, a bad `$name`, a missing or
//! cyclic include) are located directly.
//!
//! **Bounded.** A small file must not make the reader do unbounded work: besides the depth of
//! includes and of elements, the files read are counted with repeats ([`MAX_INCLUDED_FILES`],
//! and their text together at most [`crate::infile::INCLUDE`]'s limit), so that includes that
//! fan out (each file including the next twice) stop long before 2^30 reads; a substituted
//! value is at most [`MAX_VALUE_BYTES`] and all substitutions together at most
//! [`MAX_EXPANDED_BYTES`], so that `<default>`s that double each other stop at once; and
//! messages quote a value by its first characters ([`crate::errors::excerpt`]).

use crate::brdf::params::line_of;
use crate::scene::error::SceneError;
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Deepest accepted nesting of includes (a chain, not a cycle, which is refused at once).
const MAX_INCLUDE_DEPTH: usize = 32;
/// Deepest accepted nesting of elements (Mitsuba's subset needs five levels). roxmltree's
/// parser and the copy here recurse per level, so a deeper file is refused by [`too_deep`]
/// before either can exhaust the stack.
const MAX_ELEMENT_DEPTH: usize = 64;
/// Most files read for one scene, the scene file and every include counted each time it is
/// read.
const MAX_INCLUDED_FILES: usize = 1024;
/// Longest attribute value after its `$name`s are substituted.
const MAX_VALUE_BYTES: usize = 64 * 1024;
/// Most bytes that substitutions may produce in one scene, all attributes together.
const MAX_EXPANDED_BYTES: usize = 64 << 20;

/// One XML element, owned, with `$name`s substituted.
#[derive(Debug)]
pub(super) struct El {
    pub(super) tag: String,
    pub(super) attrs: Vec<(String, String)>,
    pub(super) children: Vec<El>,
    /// Byte span of the element in [`Files::source`].
    pub(super) span: Range<usize>,
    /// Where the element is, for messages: `scene/shape[2]/bsdf`.
    pub(super) path: String,
    /// The directory of the file it was written in (relative file names resolve there).
    pub(super) dir: PathBuf,
}

impl El {
    pub(super) fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }
    /// `<tag type="…">` or `<tag>` for messages.
    pub(super) fn describe(&self) -> String {
        match self.attr("type") {
            Some(t) => format!("<{} type=\"{t}\">", self.tag),
            None => match self.attr("name") {
                Some(n) => format!("<{} name=\"{n}\">", self.tag),
                None => format!("<{}>", self.tag),
            },
        }
    }
}

/// Every file read for one scene: their texts concatenated (`source`), where each starts
/// (`parts`, after the first), and the scene's top-level elements.
pub(super) struct Files {
    pub(super) source: String,
    pub(super) parts: Vec<(usize, String)>,
    pub(super) elements: Vec<El>,
    /// Bytes of the included files read (the scene file itself not counted).
    pub(super) bytes_read: u64,
    /// The command line's `-D` names that no `$name` of the scene used, sorted.
    pub(super) unused_defines: Vec<String>,
}

struct Reader {
    source: String,
    parts: Vec<(usize, String)>,
    /// Parameters: `-D name=value` first (they win), then each `<default>` not given there.
    params: HashMap<String, String>,
    /// The files being read, outermost first (a cycle is an include of one of them).
    stack: Vec<PathBuf>,
    /// Files read so far, with repeats ([`MAX_INCLUDED_FILES`]).
    files: usize,
    /// Bytes of included files read so far, with repeats.
    bytes_read: u64,
    /// Bytes produced by substitutions so far ([`MAX_EXPANDED_BYTES`]).
    expanded: usize,
    /// The parameters some `$name` used.
    used: std::collections::HashSet<String>,
}

fn invalid(file: &str, line: Option<usize>, field: Option<&str>, msg: String) -> SceneError {
    SceneError::Invalid {
        file: file.to_string(),
        line,
        field: field.map(str::to_string),
        message: msg,
    }
}

/// Read the scene file `path` (text `text`) and everything it includes.
pub(super) fn read(
    path: &Path,
    text: &str,
    defines: &[(String, String)],
) -> Result<Files, SceneError> {
    let mut r = Reader {
        source: String::new(),
        parts: Vec::new(),
        params: defines.iter().cloned().collect(),
        stack: Vec::new(),
        files: 0,
        bytes_read: 0,
        expanded: 0,
        used: std::collections::HashSet::new(),
    };
    let elements = r.file(path, text)?;
    let mut unused_defines: Vec<String> = defines
        .iter()
        .map(|(name, _)| name.clone())
        .filter(|name| !r.used.contains(name))
        .collect();
    unused_defines.sort_unstable();
    unused_defines.dedup();
    Ok(Files {
        source: r.source,
        parts: r.parts,
        elements,
        bytes_read: r.bytes_read,
        unused_defines,
    })
}

impl Reader {
    /// One file: its `<scene>`'s children, includes spliced in.
    fn file(&mut self, path: &Path, text: &str) -> Result<Vec<El>, SceneError> {
        let file = crate::errors::shown_path(path);
        self.files += 1;
        let offset = self.source.len();
        if offset > 0 {
            self.parts.push((offset, file.clone()));
        }
        self.source.push_str(text);
        // A separator, so that a span never ends exactly where the next file starts.
        self.source.push('\n');
        self.stack
            .push(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()));
        if let Some(at) = too_deep(text) {
            let msg = format!("elements nest deeper than {MAX_ELEMENT_DEPTH} levels");
            return Err(invalid(&file, Some(line_of(text, at)), None, msg));
        }
        let doc = roxmltree::Document::parse(text).map_err(|e| {
            let line = e.pos().row as usize;
            invalid(&file, Some(line), None, format!("malformed XML: {e}"))
        })?;
        let root = doc.root_element();
        let at = |n: roxmltree::Node| line_of(text, n.range().start);
        if root.tag_name().name() != "scene" {
            let msg = format!(
                "the root element is <{}>: a Mitsuba 3 scene file starts with <scene version=\"3.x.y\">",
                root.tag_name().name()
            );
            return Err(invalid(&file, Some(at(root)), Some("scene"), msg));
        }
        match root.attribute("version") {
            // Mitsuba 2 wrote the format Mitsuba 3 reads, and Mitsuba 3 loads its files as they
            // are; older files (0.x) have other parameter names, which Mitsuba 3 renames on load.
            Some(v) if matches!(v.split('.').next(), Some("2" | "3")) => {}
            Some(v) => {
                let msg = format!(
                    "version \"{}\": only Mitsuba 2 and 3 scenes (version=\"2.x.y\" or \"3.x.y\") are read; an older file's parameter names differ (Mitsuba 3 upgrades them when it loads one)",
                    crate::errors::excerpt(v)
                );
                return Err(invalid(&file, Some(at(root)), Some("scene"), msg));
            }
            None => {
                let msg = "the <scene> element has no version: write <scene version=\"3.0.0\">";
                return Err(invalid(
                    &file,
                    Some(at(root)),
                    Some("scene"),
                    msg.to_string(),
                ));
            }
        }
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let cx = FileCx {
            file: &file,
            text,
            offset,
            dir: &dir,
        };
        let mut out = Vec::new();
        let mut counts: HashMap<String, usize> = HashMap::new();
        for node in root.children() {
            if let Some(el) = self.node(&cx, node, "scene", &mut counts)? {
                match el.tag.as_str() {
                    "include" => out.extend(self.include(&cx, &el)?),
                    "default" => {}
                    _ => out.push(el),
                }
            }
        }
        self.stack.pop();
        Ok(out)
    }

    /// An `<include filename="…"/>`: the included scene's elements.
    fn include(&mut self, cx: &FileCx, el: &El) -> Result<Vec<El>, SceneError> {
        let line = Some(line_of(cx.text, el.span.start - cx.offset));
        let Some(name) = el.attr("filename") else {
            let msg = "<include> needs a filename attribute".to_string();
            return Err(invalid(cx.file, line, Some(&el.path), msg));
        };
        let full = cx.dir.join(name);
        let canon = std::fs::canonicalize(&full).unwrap_or_else(|_| full.clone());
        if self.stack.contains(&canon) {
            let chain: Vec<String> = self.stack.iter().map(|p| p.display().to_string()).collect();
            let msg = format!(
                "cyclic include: '{}' is already being read ({} → {})",
                full.display(),
                chain.join(" → "),
                canon.display()
            );
            return Err(invalid(cx.file, line, Some(&el.path), msg));
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            let msg = format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files");
            return Err(invalid(cx.file, line, Some(&el.path), msg));
        }
        let shown = crate::errors::shown_path(&full);
        if self.files >= MAX_INCLUDED_FILES {
            let msg = format!(
                "'{shown}': the scene reads more than {MAX_INCLUDED_FILES} files (an include counts \
                 each time it is read: includes that include each other more than once multiply)"
            );
            return Err(invalid(cx.file, line, Some(&el.path), msg));
        }
        let text = self.read_include(&full).map_err(|e| {
            let msg = format!("cannot read the included file '{shown}': {e}");
            invalid(cx.file, line, Some(&el.path), msg)
        })?;
        self.file(&full, &text)
    }

    /// The text of an included file, its bytes added to the scene's: all included text together
    /// is held to [`crate::infile::INCLUDE`]'s limit.
    fn read_include(&mut self, full: &Path) -> std::io::Result<String> {
        let kind = crate::infile::INCLUDE;
        let (f, len) = crate::infile::open(full, kind)?;
        if self.bytes_read.saturating_add(len) > kind.limit {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "the included files add up to more than {} (an include counts each time it \
                     is read; {} before this one)",
                    crate::infile::fmt_bytes(kind.limit),
                    crate::infile::fmt_bytes(self.bytes_read)
                ),
            ));
        }
        let bytes = crate::infile::read_opened(f, len, kind)?;
        self.bytes_read += bytes.len() as u64;
        String::from_utf8(bytes).map_err(|e| {
            crate::errors::utf8_of(e.as_bytes())
                .err()
                .unwrap_or_else(|| std::io::Error::other("not UTF-8 text"))
        })
    }

    /// One node: `None` for comments, processing instructions and white space; text is an error.
    fn node(
        &mut self,
        cx: &FileCx,
        node: roxmltree::Node,
        parent: &str,
        counts: &mut HashMap<String, usize>,
    ) -> Result<Option<El>, SceneError> {
        let line = || Some(line_of(cx.text, node.range().start));
        if node.is_text() {
            let t = node.text().unwrap_or_default().trim();
            if t.is_empty() {
                return Ok(None);
            }
            let msg = format!(
                "unexpected text '{t}' in <{}>: values are attributes",
                parent.rsplit('/').next().unwrap_or(parent)
            );
            return Err(invalid(cx.file, line(), Some(parent), msg));
        }
        if !node.is_element() {
            return Ok(None);
        }
        let tag = node.tag_name().name().to_string();
        let n = counts.entry(tag.clone()).or_insert(0);
        let path = format!("{parent}/{tag}[{n}]");
        *n += 1;
        let mut attrs = Vec::new();
        for a in node.attributes() {
            let v = self
                .substitute(a.value())
                .map_err(|msg| invalid(cx.file, line(), Some(&path), msg))?;
            attrs.push((a.name().to_string(), v));
        }
        if let Some(msg) = attribute_error(&tag, &attrs) {
            return Err(invalid(cx.file, line(), Some(&path), msg));
        }
        let span = cx.offset + node.range().start..cx.offset + node.range().end;
        let mut el = El {
            tag,
            attrs,
            children: Vec::new(),
            span,
            path,
            dir: cx.dir.to_path_buf(),
        };
        if el.tag == "default" {
            let (Some(name), Some(value)) = (node.attribute("name"), el.attr("value")) else {
                let msg = "<default> needs name and value attributes".to_string();
                return Err(invalid(cx.file, line(), Some(&el.path), msg));
            };
            if parent != "scene" {
                let msg = "<default> is allowed only directly inside <scene>".to_string();
                return Err(invalid(cx.file, line(), Some(&el.path), msg));
            }
            self.params
                .entry(name.to_string())
                .or_insert_with(|| value.to_string());
        }
        let mut inner: HashMap<String, usize> = HashMap::new();
        for c in node.children() {
            if let Some(child) = self.node(cx, c, &el.path.clone(), &mut inner)? {
                if child.tag == "include" || child.tag == "default" {
                    let msg = format!("<{}> is allowed only directly inside <scene>", child.tag);
                    let l = Some(line_of(cx.text, child.span.start - cx.offset));
                    return Err(invalid(cx.file, l, Some(&child.path), msg));
                }
                el.children.push(child);
            }
        }
        Ok(Some(el))
    }

    /// Replace every `$name` by its parameter's value (Mitsuba's rule: a name is letters,
    /// digits and underscores). The result is held to [`MAX_VALUE_BYTES`], and all results
    /// together to [`MAX_EXPANDED_BYTES`], checked before each value is copied in.
    fn substitute(&mut self, v: &str) -> Result<String, String> {
        if !v.contains('$') {
            return Ok(v.to_string());
        }
        let shown = crate::errors::excerpt(v);
        let mut out = String::new();
        let mut rest = v;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            if name.is_empty() {
                return Err(format!(
                    "'{shown}': a '$' must be followed by a parameter name"
                ));
            }
            match self.params.get(name) {
                Some(value) => {
                    if out.len() + value.len() > MAX_VALUE_BYTES {
                        return Err(format!(
                            "'{shown}': with ${name} substituted the value is longer than \
                             {MAX_VALUE_BYTES} bytes (do parameters repeat each other?)"
                        ));
                    }
                    if self.expanded + value.len() > MAX_EXPANDED_BYTES {
                        return Err(format!(
                            "'{shown}': the scene's parameter substitutions add up to more than \
                             {} (do parameters repeat each other?)",
                            crate::infile::fmt_bytes(MAX_EXPANDED_BYTES as u64)
                        ));
                    }
                    self.expanded += value.len();
                    out.push_str(value);
                    self.used.insert(name.to_string());
                }
                None => {
                    let mut known: Vec<&str> = self.params.keys().map(String::as_str).collect();
                    known.sort_unstable();
                    let known = if known.is_empty() {
                        "none is defined".to_string()
                    } else {
                        format!("defined: {}", known.join(", "))
                    };
                    return Err(format!(
                        "'{shown}': unknown parameter ${name} ({known}); define it with <default name=\"{name}\" value=\"…\"/> or on the command line with -D {name}=…"
                    ));
                }
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// The attributes an element of `tag` takes (Mitsuba 3's), for the elements brdfwave reads;
/// `None` for other tags, which the plugin mapping refuses by name.
fn attributes_of(tag: &str) -> Option<&'static [&'static str]> {
    Some(match tag {
        "scene" => &["version"],
        "float" | "integer" | "boolean" | "string" | "rgb" => &["name", "value"],
        "spectrum" => &["name", "value", "filename"],
        "point" | "vector" => &["name", "value", "x", "y", "z"],
        "translate" | "scale" => &["value", "x", "y", "z"],
        "rotate" => &["value", "x", "y", "z", "angle"],
        "matrix" => &["value"],
        "lookat" => &["origin", "target", "up"],
        "transform" => &["name"],
        "ref" => &["id", "name"],
        "include" => &["filename"],
        "default" => &["name", "value"],
        "bsdf" | "shape" | "emitter" | "sensor" | "film" | "sampler" | "integrator" | "rfilter"
        | "texture" | "medium" | "phase" | "volume" => &["type", "id", "name"],
        _ => return None,
    })
}

/// Why the attributes of an element of `tag` are wrong: one it does not take (which would be
/// ignored), or `value` beside `x`, `y` or `z` (where one would silently win).
fn attribute_error(tag: &str, attrs: &[(String, String)]) -> Option<String> {
    let allowed = attributes_of(tag)?;
    if let Some((name, _)) = attrs.iter().find(|(a, _)| !allowed.contains(&a.as_str())) {
        return Some(format!(
            "<{tag}> does not take the attribute '{}' (it takes {})",
            crate::errors::excerpt(name),
            allowed.join(", ")
        ));
    }
    let has = |a: &str| attrs.iter().any(|(k, _)| k == a);
    let xyz: Vec<&str> = ["x", "y", "z"].into_iter().filter(|a| has(a)).collect();
    if has("value") && !xyz.is_empty() {
        return Some(format!(
            "<{tag}> has both value and {}: give either value or x, y, z",
            xyz.join(", ")
        ));
    }
    None
}

struct FileCx<'a> {
    file: &'a str,
    text: &'a str,
    offset: usize,
    dir: &'a Path,
}

/// The offset of the first tag that opens an element deeper than [`MAX_ELEMENT_DEPTH`], by a
/// linear scan that skips comments, CDATA, processing instructions and declarations and reads
/// quoted attribute values whole (malformed text is left to the parser's message).
fn too_deep(text: &str) -> Option<usize> {
    let b = text.as_bytes();
    let (mut i, mut depth) = (0usize, 0usize);
    let skip_to = |from: usize, end: &str| {
        text[from..]
            .find(end)
            .map_or(b.len(), |k| from + k + end.len())
    };
    while let Some(k) = text[i..].find('<') {
        let at = i + k;
        let rest = &text[at..];
        if rest.starts_with("<!--") {
            i = skip_to(at, "-->");
        } else if rest.starts_with("<![CDATA[") {
            i = skip_to(at, "]]>");
        } else if rest.starts_with("<?") {
            i = skip_to(at, "?>");
        } else if rest.starts_with("<!") {
            i = skip_to(at, ">");
        } else if rest.starts_with("</") {
            depth = depth.saturating_sub(1);
            i = skip_to(at, ">");
        } else {
            // The tag's end, outside quoted attribute values.
            let mut j = at + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, q @ (b'"' | b'\'')) => quote = Some(q),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            if j < b.len() && b[j - 1] != b'/' {
                depth += 1;
                if depth > MAX_ELEMENT_DEPTH {
                    return Some(at);
                }
            }
            i = (j + 1).min(b.len());
        }
        if i >= b.len() {
            break;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The depth scan counts open elements only: self-closing tags, closing tags, comments,
    /// CDATA, declarations and a '>' inside a quoted value do not nest.
    #[test]
    fn depth_scan_counts_open_elements() {
        let nest =
            |n: usize, inner: &str| format!("{}{inner}{}", "<a>".repeat(n), "</a>".repeat(n));
        assert_eq!(too_deep(&nest(MAX_ELEMENT_DEPTH, "")), None);
        assert_eq!(
            too_deep(&nest(MAX_ELEMENT_DEPTH + 1, "")),
            Some(3 * MAX_ELEMENT_DEPTH)
        );
        let noise = "<b x='>' y=\"<\"/><!-- <c> --><![CDATA[<d>]]><?pi <e>?><!DOCTYPE f>";
        let many = noise.repeat(1000);
        assert_eq!(too_deep(&nest(MAX_ELEMENT_DEPTH, &many)), None);
        assert_eq!(too_deep("<a x='unterminated"), None);
    }
}
