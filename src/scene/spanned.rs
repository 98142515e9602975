//! The span-tracking layer over `toml`: values that remember where in the scene file they
//! were written ([`Sp`]), and the context ([`Cx`]) that turns a byte span into the
//! `file:line: field 'a.b': …` form of every scene error, including the errors of serde, which
//! carry only a span: their field path is recovered by re-reading the document as a tree of
//! spanned keys ([`Node`]) and finding the innermost key or value that contains the span.

use super::error::SceneError;
use crate::brdf::params::line_of;
use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{
    self, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, SeqAccess, Visitor,
};
use serde::Deserialize;
use std::fmt;
use std::marker::PhantomData;
use std::ops::Range;
use std::path::PathBuf;

/// The names of `toml::Spanned`'s serde protocol (`serde_spanned::__unstable`, which
/// toml 0.8 implements); `spanned_protocol_matches_toml` below checks they still work.
const SPANNED_NAME: &str = "$__serde_spanned_private_Spanned";
const SPANNED_START: &str = "$__serde_spanned_private_start";
const SPANNED_END: &str = "$__serde_spanned_private_end";
const SPANNED_VALUE: &str = "$__serde_spanned_private_value";
const SPANNED_FIELDS: &[&str] = &[SPANNED_START, SPANNED_END, SPANNED_VALUE];

/// A value and its byte span in the source, like `toml::Spanned`, except that a table
/// TOML creates implicitly (through dotted keys: `sphere.radius = 1` or `[a.b]` without
/// `[a]`) has no span and is read with `span = None`, where `toml::Spanned` would fail.
#[derive(Clone)]
pub(super) struct Sp<T> {
    pub(super) span: Option<Range<usize>>,
    pub(super) value: T,
}

impl<T> Sp<T> {
    pub(super) fn span(&self) -> Option<Range<usize>> {
        self.span.clone()
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Sp<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, SpVisitor(PhantomData))
    }
}

pub(super) struct SpVisitor<T>(PhantomData<T>);

pub(super) fn plain<'de, T: Deserialize<'de>, D: Deserializer<'de>>(
    d: D,
) -> Result<Sp<T>, D::Error> {
    T::deserialize(d).map(|value| Sp { span: None, value })
}

impl<'de, T: Deserialize<'de>> Visitor<'de> for SpVisitor<T> {
    type Value = Sp<T>;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a value")
    }
    fn visit_bool<E: de::Error>(self, v: bool) -> Result<Sp<T>, E> {
        plain(v.into_deserializer())
    }
    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Sp<T>, E> {
        plain(v.into_deserializer())
    }
    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Sp<T>, E> {
        plain(v.into_deserializer())
    }
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Sp<T>, E> {
        plain(v.into_deserializer())
    }
    fn visit_str<E: de::Error>(self, v: &str) -> Result<Sp<T>, E> {
        plain(v.to_string().into_deserializer())
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Sp<T>, A::Error> {
        plain(SeqAccessDeserializer::new(seq))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Sp<T>, A::Error> {
        let first: Option<Key> = map.next_key()?;
        if first.as_ref().is_some_and(|k| k.0 == SPANNED_START) {
            let start: usize = map.next_value()?;
            expect_key(&mut map, SPANNED_END)?;
            let end: usize = map.next_value()?;
            expect_key(&mut map, SPANNED_VALUE)?;
            let value: T = map.next_value()?;
            return Ok(Sp {
                span: Some(start..end),
                value,
            });
        }
        // A table without a span: its entries, starting with the key already read.
        plain(MapAccessDeserializer::new(Replay {
            first: first.map(|k| k.0),
            map,
        }))
    }
}

pub(super) fn expect_key<'de, A: MapAccess<'de>>(
    map: &mut A,
    name: &'static str,
) -> Result<(), A::Error> {
    match map.next_key::<Key>()? {
        Some(k) if k.0 == name => Ok(()),
        _ => Err(de::Error::missing_field(name)),
    }
}

/// A table key (owned, whether the deserializer lends or gives it).
pub(super) struct Key(pub(super) String);

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d).map(Key)
    }
}

/// A map whose first key has already been read.
pub(super) struct Replay<A> {
    first: Option<String>,
    map: A,
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for Replay<A> {
    type Error = A::Error;
    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        match self.first.take() {
            Some(k) => seed.deserialize(k.into_deserializer()).map(Some),
            None => self.map.next_key_seed(seed),
        }
    }
    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

pub(super) struct Cx<'a> {
    pub(super) file: String,
    pub(super) source: &'a str,
    pub(super) dir: PathBuf,
    pub(super) warnings: Vec<String>,
    /// A scene read from several files (Mitsuba XML with `include`s) has their texts
    /// concatenated in `source`: `(start offset, file name)` of each after the first, ascending.
    pub(super) parts: Vec<(usize, String)>,
    /// Bytes of the files the scene refers to read so far (a file counts each time it is
    /// referred to), held to [`SCENE_READ_LIMIT`].
    pub(super) read_bytes: u64,
}

/// The most bytes the files one scene refers to (includes, meshes, MTL libraries) may add up
/// to, counting a file once per reference: a small scene that names one large mesh a thousand
/// times must not read it a thousand times.
pub(super) const SCENE_READ_LIMIT: u64 = 16 << 30;

/// Why a referenced file of `len` bytes may not be read after `read` bytes of others
/// ([`SCENE_READ_LIMIT`]), if it may not.
fn over_scene_limit(read: u64, len: u64) -> Option<String> {
    (read.saturating_add(len) > SCENE_READ_LIMIT).then(|| {
        format!(
            "{} more would take the files this scene refers to past {} (a file counts each \
             time it is referred to; {} read before it)",
            crate::infile::fmt_bytes(len),
            crate::infile::fmt_bytes(SCENE_READ_LIMIT),
            crate::infile::fmt_bytes(read)
        )
    })
}

impl<'a> Cx<'a> {
    /// The context of the scene file `file` (as messages show it) with text `source`.
    pub(super) fn new(file: String, source: &'a str) -> Cx<'a> {
        Cx {
            file,
            source,
            dir: PathBuf::new(),
            warnings: Vec::new(),
            parts: Vec::new(),
            read_bytes: 0,
        }
    }

    /// Reads `path`, a `kind` file the scene refers to ([`crate::infile::read`]: a regular file
    /// within the kind's limit), and adds its size to the scene's reads
    /// ([`SCENE_READ_LIMIT`]).
    pub(super) fn read_referenced(
        &mut self,
        path: &std::path::Path,
        kind: crate::infile::Kind,
    ) -> std::io::Result<Vec<u8>> {
        let (file, len) = crate::infile::open(path, kind)?;
        if let Some(msg) = over_scene_limit(self.read_bytes, len) {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, msg));
        }
        let bytes = crate::infile::read_opened(file, len, kind)?;
        self.read_bytes += bytes.len() as u64;
        Ok(bytes)
    }

    /// [`Cx::read_referenced`] as UTF-8 text (invalid UTF-8 located).
    pub(super) fn read_referenced_text(
        &mut self,
        path: &std::path::Path,
        kind: crate::infile::Kind,
    ) -> std::io::Result<String> {
        let bytes = self.read_referenced(path, kind)?;
        String::from_utf8(bytes).map_err(|e| {
            crate::errors::utf8_of(e.as_bytes())
                .err()
                .unwrap_or_else(|| std::io::Error::other("not UTF-8 text"))
        })
    }
}

impl Cx<'_> {
    /// The file that holds byte `offset` of `source`, its text, and the offset where it starts.
    pub(super) fn part_of(&self, offset: usize) -> (&str, &str, usize) {
        let i = self.parts.partition_point(|(start, _)| *start <= offset);
        let (start, file) = match i {
            0 => (0, self.file.as_str()),
            _ => (self.parts[i - 1].0, self.parts[i - 1].1.as_str()),
        };
        let end = self.parts.get(i).map_or(self.source.len(), |p| p.0);
        (file, &self.source[start..end], start)
    }

    pub(super) fn err(
        &self,
        span: Option<Range<usize>>,
        field: &str,
        msg: impl fmt::Display,
    ) -> SceneError {
        let (file, text, start) = self.part_of(span.as_ref().map_or(0, |s| s.start));
        SceneError::Invalid {
            file: file.to_string(),
            line: span.map(|s| line_of(text, s.start - start)),
            field: Some(field.to_string()),
            message: msg.to_string(),
        }
    }

    pub(super) fn warn(&mut self, span: Option<Range<usize>>, field: &str, msg: impl fmt::Display) {
        let e = self.err(span, field, msg);
        self.warnings.push(format!("warning: {e}"));
    }

    /// Turn a TOML syntax or serde error into a located error, recovering the field path
    /// from the error's span.
    pub(super) fn toml_error(&self, e: &toml::de::Error) -> SceneError {
        let mut message = e.message().trim().replace('\n', ": ");
        let mut field = None;
        let mut line = None;
        // Serde reports a missing top-level table with the empty span 0..0: no line, no field.
        let span = e.span().filter(|s| *s != (0..0));
        if let Some(span) = span {
            if let Ok(tree) = toml::from_str::<Sp<Node>>(self.source) {
                let mut path = String::new();
                locate(&tree.value, &span, &mut path);
                if !path.is_empty() {
                    field = Some(path);
                }
            }
            line = Some(line_of(self.source, span.start));
        }
        // Serde's "unknown field `x`, expected …" and "missing field `x`": put x in the path
        // when the span stopped at the enclosing table.
        for prefix in ["missing field `", "unknown field `"] {
            if let Some(rest) = message.strip_prefix(prefix) {
                let name = rest.split('`').next().unwrap_or_default().to_string();
                let ends_with_name = field
                    .as_deref()
                    .is_some_and(|p| p == name || p.ends_with(&format!(".{name}")));
                if !ends_with_name {
                    field = Some(match field {
                        Some(p) => format!("{p}.{name}"),
                        None => name.clone(),
                    });
                }
                if prefix.starts_with("missing") {
                    message = "missing: this field is required (see scenes/README.md)".to_string();
                } else {
                    message = match rest.split_once(", ") {
                        Some((_, expected)) => format!("unknown field: {expected}"),
                        None => "unknown field".to_string(),
                    };
                }
            }
        }
        SceneError::Invalid {
            file: self.file.clone(),
            line,
            field,
            message: plain_types(&message),
        }
    }
}

/// Serde names the Rust type it wanted ("expected f64", "expected u32"); say it in the scene
/// format's words.
pub(super) fn plain_types(message: &str) -> String {
    const WORDS: [(&str, &str); 6] = [
        ("expected f64", "expected a number"),
        ("expected f32", "expected a number"),
        (
            "expected u32",
            "expected a whole number from 0 to 4294967295",
        ),
        ("expected u64", "expected a whole number >= 0"),
        ("expected usize", "expected a whole number >= 0"),
        ("expected i64", "expected a whole number"),
    ];
    let mut m = message.to_string();
    for (rust, plain) in WORDS {
        m = m.replace(rust, plain);
    }
    m
}

/// The document as a tree of spanned keys and values, only used to name the field of a
/// serde error.
pub(super) enum Node {
    Table(Vec<(Sp<Key>, Sp<Node>)>),
    Array(Vec<Sp<Node>>),
    Leaf,
}

impl<'de> Deserialize<'de> for Node {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Node;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("any TOML value")
            }
            fn visit_bool<E>(self, _: bool) -> Result<Node, E> {
                Ok(Node::Leaf)
            }
            fn visit_i64<E>(self, _: i64) -> Result<Node, E> {
                Ok(Node::Leaf)
            }
            fn visit_u64<E>(self, _: u64) -> Result<Node, E> {
                Ok(Node::Leaf)
            }
            fn visit_f64<E>(self, _: f64) -> Result<Node, E> {
                Ok(Node::Leaf)
            }
            fn visit_str<E>(self, _: &str) -> Result<Node, E> {
                Ok(Node::Leaf)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Node, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = seq.next_element()? {
                    v.push(x);
                }
                Ok(Node::Array(v))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
                let mut v = Vec::new();
                while let Some(k) = map.next_key()? {
                    v.push((k, map.next_value()?));
                }
                Ok(Node::Table(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// Whether the error span starts inside `outer`.
pub(super) fn starts_in(outer: &Option<Range<usize>>, inner: &Range<usize>) -> bool {
    outer
        .as_ref()
        .is_some_and(|o| o.start <= inner.start && (inner.start < o.end || o == inner))
}

/// Whether the error lies somewhere below `node` (also for tables without a span).
pub(super) fn inside(node: &Sp<Node>, span: &Range<usize>) -> bool {
    if node.span.is_some() {
        return starts_in(&node.span, span);
    }
    match &node.value {
        Node::Table(entries) => entries
            .iter()
            .any(|(k, v)| starts_in(&k.span, span) || inside(v, span)),
        Node::Array(items) => items.iter().any(|v| inside(v, span)),
        Node::Leaf => false,
    }
}

/// Append to `path` the dotted path of the innermost key or value containing `span`.
pub(super) fn locate(node: &Node, span: &Range<usize>, path: &mut String) {
    match node {
        Node::Table(entries) => {
            for (k, v) in entries {
                let in_key = starts_in(&k.span, span);
                if in_key || inside(v, span) {
                    if !path.is_empty() {
                        path.push('.');
                    }
                    path.push_str(&k.value.0);
                    if !in_key {
                        locate(&v.value, span, path);
                    }
                    return;
                }
            }
        }
        Node::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                if inside(v, span) {
                    path.push_str(&format!("[{i}]"));
                    locate(&v.value, span, path);
                    return;
                }
            }
        }
        Node::Leaf => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// `Sp` speaks toml's span protocol: spans for explicit values and tables, `None` for
    /// tables made by dotted keys.
    #[test]
    fn spanned_protocol_matches_toml() {
        #[derive(Deserialize)]
        struct Doc {
            a: Sp<f64>,
            t: Sp<BTreeMap<String, Sp<i64>>>,
            d: Sp<BTreeMap<String, Sp<i64>>>,
        }
        let src = "a = 1.5\nd.x = 7\n[t]\ny = 2\n";
        let doc: Doc = toml::from_str(src).unwrap();
        assert_eq!(doc.a.span, Some(4..7));
        assert_eq!(doc.a.value, 1.5);
        assert_eq!(doc.t.span.map(|s| line_of(src, s.start)), Some(3));
        assert_eq!(
            doc.t.value["y"].span.clone().map(|s| line_of(src, s.start)),
            Some(4)
        );
        assert!(doc.d.span.is_none());
        assert_eq!(doc.d.value["x"].value, 7);
        assert_eq!(
            doc.d.value["x"].span.clone().map(|s| line_of(src, s.start)),
            Some(2)
        );
    }

    /// The files a scene refers to add up to at most the limit, repeats counted.
    #[test]
    fn referenced_files_add_up_to_the_scene_limit() {
        assert_eq!(over_scene_limit(0, SCENE_READ_LIMIT), None);
        assert_eq!(over_scene_limit(SCENE_READ_LIMIT - 5, 5), None);
        let e = over_scene_limit(SCENE_READ_LIMIT - 5, 6).unwrap();
        assert!(
            e.contains("past 16 GiB") && e.contains("each time it is referred to"),
            "{e}"
        );
        assert!(over_scene_limit(u64::MAX, 1).is_some());
    }
}
