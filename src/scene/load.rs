//! The scene file loader: TOML text → [`Scene`].
//!
//! The format is documented field by field in `scenes/README.md`. Loading happens in two
//! steps: serde reads the text into private `Raw*` structs (every table
//! `deny_unknown_fields`, every value wrapped in [`Sp`] so that its line is known), then
//! [`load_str`] checks the values and builds the flat primitive lists of [`Scene`].
//!
//! Every error names the file and, when they exist, the line and the dotted field path
//! (`box.toml:12: field 'shapes[3].sphere.radius': -1 is out of range …`). Serde errors carry
//! only a byte span; their field path is recovered by re-reading the document as a tree of
//! spanned keys and finding the innermost key or value that contains the span.
//! Loading never panics on any input.

use super::{Camera, Emitter, Integrator, Scene, Sphere, Triangle};
use crate::brdf::params::{fmt_num, line_of};
use crate::brdf::{self, Origin, ParamError};
use glam::{Vec2, Vec3};
use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{
    self, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, SeqAccess, Visitor,
};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::marker::PhantomData;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Largest accepted film width or height in pixels.
pub const MAX_FILM_SIZE: u32 = 16384;

/// Why a scene could not be loaded. The `Display` text always starts with the scene file's
/// name, followed by the line and the field when they are known:
/// `file:line: field 'a.b': what is wrong`.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file itself could not be read.
    #[error("{file}: cannot read the scene file: {source}")]
    Read {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// Anything wrong with the contents: syntax, types, values, referenced OBJ files.
    #[error("{}", located(file, *line, field.as_deref(), message))]
    Invalid {
        file: String,
        /// 1-based line in the scene file.
        line: Option<usize>,
        /// Dotted path of the offending field, e.g. `shapes[2].sphere.radius`
        /// (array indices are 0-based, in file order).
        field: Option<String>,
        message: String,
    },
    /// A material's parameters are wrong; the message (from [`crate::brdf`]) is already
    /// `file:line: material 'name', field 'f': …`.
    #[error(transparent)]
    Material(#[from] ParamError),
}

fn located(file: &str, line: Option<usize>, field: Option<&str>, message: &str) -> String {
    let mut s = file.to_string();
    if let Some(l) = line {
        s.push_str(&format!(":{l}"));
    }
    s.push_str(": ");
    if let Some(f) = field {
        s.push_str(&format!("field '{f}': "));
    }
    s.push_str(message);
    s
}

/// Read and load a scene file. Relative OBJ paths are resolved against the file's directory.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let source = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        file: path.display().to_string(),
        source,
    })?;
    load_str(&source, path)
}

/// Load a scene from its text. `path` names the scene in messages and its parent directory
/// is where relative OBJ paths are looked up; the file itself is not read.
///
/// Legal but suspicious content (unused materials, skipped zero-area OBJ triangles, ignored
/// MTL files, …) is reported in [`Scene::warnings`].
pub fn load_str(source: &str, path: &Path) -> Result<Scene, SceneError> {
    let mut cx = Cx {
        file: path.display().to_string(),
        source,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        warnings: Vec::new(),
    };
    let raw: RawScene = toml::from_str(source).map_err(|e| cx.toml_error(&e))?;
    build(&mut cx, raw, path)
}

// ---------------------------------------------------------------------------------------------
// Spanned values that also accept tables without a span.

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
struct Sp<T> {
    span: Option<Range<usize>>,
    value: T,
}

impl<T> Sp<T> {
    fn span(&self) -> Option<Range<usize>> {
        self.span.clone()
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Sp<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, SpVisitor(PhantomData))
    }
}

struct SpVisitor<T>(PhantomData<T>);

fn plain<'de, T: Deserialize<'de>, D: Deserializer<'de>>(d: D) -> Result<Sp<T>, D::Error> {
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

fn expect_key<'de, A: MapAccess<'de>>(map: &mut A, name: &'static str) -> Result<(), A::Error> {
    match map.next_key::<Key>()? {
        Some(k) if k.0 == name => Ok(()),
        _ => Err(de::Error::missing_field(name)),
    }
}

/// A table key (owned, whether the deserializer lends or gives it).
struct Key(String);

impl<'de> Deserialize<'de> for Key {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d).map(Key)
    }
}

/// A map whose first key has already been read.
struct Replay<A> {
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

// ---------------------------------------------------------------------------------------------
// Raw (serde) form of the file.

type V3 = Sp<[f64; 3]>;
type Quads = Vec<Sp<[[f64; 3]; 4]>>;
type Tris = Vec<Sp<[[f64; 3]; 3]>>;
/// A material's fields, given to [`brdf::parse_material`].
type MaterialTable = BTreeMap<String, Sp<toml::Value>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    camera: RawCamera,
    film: RawFilm,
    integrator: Option<RawIntegrator>,
    environment: Option<RawEnvironment>,
    #[serde(default)]
    materials: BTreeMap<String, Sp<MaterialTable>>,
    #[serde(default)]
    shapes: Vec<Sp<RawShape>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: V3,
    target: V3,
    up: Option<V3>,
    fov_y: Sp<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFilm {
    width: Sp<u32>,
    height: Sp<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIntegrator {
    spp: Option<Sp<u32>>,
    max_depth: Option<Sp<u32>>,
    seed: Option<u32>,
    russian_roulette: Option<bool>,
    rr_start_depth: Option<Sp<u32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEnvironment {
    radiance: Option<Sp<Triple>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShape {
    name: Option<String>,
    material: Sp<String>,
    emission: Option<Sp<Triple>>,
    quads: Option<Sp<Quads>>,
    triangles: Option<Sp<Tris>>,
    sphere: Option<Sp<RawSphere>>,
    obj: Option<Sp<String>>,
    transform: Option<Sp<RawTransform>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSphere {
    center: V3,
    radius: Sp<f64>,
    #[serde(default)]
    inward: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransform {
    translate: Option<V3>,
    scale: Option<Sp<Triple>>,
    rotate_y_deg: Option<Sp<f64>>,
}

/// A number (meaning the same value three times) or an array of three numbers.
struct Triple([f64; 3]);

impl<'de> Deserialize<'de> for Triple {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Triple;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Triple, E> {
                Ok(Triple([v as f64; 3]))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Triple, E> {
                Ok(Triple([v as f64; 3]))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Triple, E> {
                Ok(Triple([v; 3]))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Triple, A::Error> {
                let mut t = [0.0; 3];
                let mut n = 0;
                while let Some(x) = seq.next_element::<f64>()? {
                    if n < 3 {
                        t[n] = x;
                    }
                    n += 1;
                }
                if n != 3 {
                    return Err(de::Error::invalid_length(n, &self));
                }
                Ok(Triple(t))
            }
        }
        d.deserialize_any(V)
    }
}

// ---------------------------------------------------------------------------------------------
// Errors: spans → lines and field paths.

struct Cx<'a> {
    file: String,
    source: &'a str,
    dir: PathBuf,
    warnings: Vec<String>,
}

impl Cx<'_> {
    fn err(&self, span: Option<Range<usize>>, field: &str, msg: impl fmt::Display) -> SceneError {
        SceneError::Invalid {
            file: self.file.clone(),
            line: span.map(|s| line_of(self.source, s.start)),
            field: Some(field.to_string()),
            message: msg.to_string(),
        }
    }

    fn warn(&mut self, span: Option<Range<usize>>, field: &str, msg: impl fmt::Display) {
        let e = self.err(span, field, msg);
        self.warnings.push(format!("warning: {e}"));
    }

    /// Turn a TOML syntax or serde error into a located error, recovering the field path
    /// from the error's span.
    fn toml_error(&self, e: &toml::de::Error) -> SceneError {
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
fn plain_types(message: &str) -> String {
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
enum Node {
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
fn starts_in(outer: &Option<Range<usize>>, inner: &Range<usize>) -> bool {
    outer
        .as_ref()
        .is_some_and(|o| o.start <= inner.start && (inner.start < o.end || o == inner))
}

/// Whether the error lies somewhere below `node` (also for tables without a span).
fn inside(node: &Sp<Node>, span: &Range<usize>) -> bool {
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
fn locate(node: &Node, span: &Range<usize>, path: &mut String) {
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

// ---------------------------------------------------------------------------------------------
// Value checks.

/// A vector for a message, `[x, y, z]`, each number as [`fmt_num`] writes it.
fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", fmt_num(v.x), fmt_num(v.y), fmt_num(v.z))
}

impl Cx<'_> {
    fn finite(&self, span: Option<Range<usize>>, field: &str, x: f64) -> Result<f32, SceneError> {
        if !x.is_finite() {
            return Err(self.err(span, field, format!("{x} is not a finite number")));
        }
        if x.abs() > f32::MAX as f64 {
            return Err(self.err(
                span,
                field,
                format!("{x:e} is out of the single-precision range"),
            ));
        }
        Ok(x as f32)
    }

    fn vec3(
        &self,
        span: Option<Range<usize>>,
        field: &str,
        v: [f64; 3],
    ) -> Result<Vec3, SceneError> {
        Ok(Vec3::new(
            self.finite(span.clone(), field, v[0])?,
            self.finite(span.clone(), field, v[1])?,
            self.finite(span, field, v[2])?,
        ))
    }

    fn v3(&self, v: &V3, field: &str) -> Result<Vec3, SceneError> {
        self.vec3(v.span(), field, v.value)
    }

    /// A non-negative RGB radiance.
    fn radiance(&self, v: &Sp<Triple>, field: &str) -> Result<Vec3, SceneError> {
        let c = self.vec3(v.span(), field, v.value.0)?;
        if c.min_element() < 0.0 {
            let msg = format!(
                "{} has a negative channel: radiance must be >= 0",
                fmt_vec(c)
            );
            return Err(self.err(v.span(), field, msg));
        }
        Ok(c)
    }

    fn at_least_one(
        &self,
        v: &Option<Sp<u32>>,
        field: &str,
        default: u32,
    ) -> Result<u32, SceneError> {
        match v {
            None => Ok(default),
            Some(x) if x.value == 0 => {
                Err(self.err(x.span(), field, "0 is out of range: must be >= 1"))
            }
            Some(x) => Ok(x.value),
        }
    }
}

/// Zero-area test: the two edges from `v0` are parallel or empty to within single precision,
/// `|e1 × e2| <= 1e-6 |e1| |e2|`, evaluated in f64 so that no finite f32 triangle overflows
/// (or underflows) into looking degenerate. An edge that itself overflows f32 (vertices of
/// opposite sign near 3.4e38) counts as degenerate here; the loaders refuse such input first
/// with a message ([`edge_overflow`]).
fn degenerate(v: &[Vec3; 3]) -> bool {
    let d = |a: Vec3| glam::DVec3::new(a.x as f64, a.y as f64, a.z as f64);
    let e1 = d(v[1]) - d(v[0]);
    let e2 = d(v[2]) - d(v[0]);
    let c = e1.cross(e2).length();
    let edges_finite = (v[1] - v[0]).is_finite() && (v[2] - v[0]).is_finite();
    !(c > 1e-6 * e1.length() * e2.length() && c.is_finite() && edges_finite)
}

/// A message when an edge `v1 - v0` or `v2 - v0` of a triangle with finite vertices is not
/// finite in f32 (the renderers work with f32 edges).
fn edge_overflow(v: &[Vec3; 3]) -> Option<String> {
    if (v[1] - v[0]).is_finite() && (v[2] - v[0]).is_finite() && (v[2] - v[1]).is_finite() {
        return None;
    }
    Some(format!(
        "the triangle {} {} {} has an edge longer than the single-precision range (about 3.4e38)",
        v[0], v[1], v[2]
    ))
}

// ---------------------------------------------------------------------------------------------
// Building the scene.

fn build(cx: &mut Cx, raw: RawScene, path: &Path) -> Result<Scene, SceneError> {
    let camera = camera(cx, &raw.camera)?;

    let size = |v: &Sp<u32>, field: &str| {
        if v.value == 0 || v.value > MAX_FILM_SIZE {
            let msg = format!(
                "{} is out of range: must be in [1, {MAX_FILM_SIZE}]",
                v.value
            );
            return Err(cx.err(v.span(), field, msg));
        }
        Ok(v.value)
    };
    let width = size(&raw.film.width, "film.width")?;
    let height = size(&raw.film.height, "film.height")?;

    let mut integrator = Integrator::default();
    if let Some(i) = &raw.integrator {
        let d = Integrator::default();
        integrator.spp = cx.at_least_one(&i.spp, "integrator.spp", d.spp)?;
        integrator.max_depth =
            cx.at_least_one(&i.max_depth, "integrator.max_depth", d.max_depth)?;
        integrator.seed = i.seed.unwrap_or(d.seed);
        integrator.russian_roulette = i.russian_roulette.unwrap_or(d.russian_roulette);
        integrator.rr_start_depth = cx.at_least_one(
            &i.rr_start_depth,
            "integrator.rr_start_depth",
            d.rr_start_depth,
        )?;
    }

    let environment = match raw.environment.as_ref().and_then(|e| e.radiance.as_ref()) {
        Some(r) => cx.radiance(r, "environment.radiance")?,
        None => Vec3::ZERO,
    };

    // Materials, in file order (the map is sorted by name; the spans give the order).
    let mut defs: Vec<(String, Option<Range<usize>>, MaterialTable)> = Vec::new();
    for (name, table) in raw.materials {
        // A table made by dotted keys has no span of its own: use its first field's.
        let span = table.span.clone().or_else(|| {
            table
                .value
                .values()
                .filter_map(|v| v.span())
                .min_by_key(|s| s.start)
        });
        defs.push((name, span, table.value));
    }
    defs.sort_by_key(|(_, span, _)| span.as_ref().map_or(0, |s| s.start));
    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    let mut material_spans = Vec::new();
    for (name, span, table) in defs {
        let mut fields = BTreeMap::new();
        for (key, v) in table {
            let Some(s) = v.span() else {
                let msg = format!(
                    "material '{name}': a parameter cannot be a table (dotted key '{key}.…')"
                );
                return Err(cx.err(span, &format!("materials.{name}.{key}"), msg));
            };
            fields.insert(key, toml::Spanned::new(s, v.value));
        }
        let table_span = span.clone().unwrap_or(0..0);
        let origin = Origin {
            file: &cx.file,
            source: cx.source,
            material: &name,
            span: table_span,
        };
        let (m, w) = brdf::parse_material(origin, fields)?;
        cx.warnings.extend(w);
        materials.push(m);
        material_names.push(name);
        material_spans.push(span);
    }
    let index: HashMap<&str, usize> = material_names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect();
    let mut used = vec![false; materials.len()];

    let mut out = Shapes::default();
    for (i, shape) in raw.shapes.iter().enumerate() {
        let f = format!("shapes[{i}]");
        let m = &shape.value.material;
        let Some(&material) = index.get(m.value.as_str()) else {
            let known = if material_names.is_empty() {
                "no materials are defined: add a [materials.NAME] table".to_string()
            } else {
                format!("defined materials: {}", material_names.join(", "))
            };
            let msg = format!("unknown material '{}' ({known})", m.value);
            return Err(cx.err(m.span(), &format!("{f}.material"), msg));
        };
        used[material] = true;
        shape_primitives(cx, &f, shape, material as u32, &mut out)?;
    }

    for (k, u) in used.iter().enumerate() {
        if !u {
            let (span, field) = (
                material_spans[k].clone(),
                format!("materials.{}", material_names[k]),
            );
            cx.warn(span, &field, "the material is defined but no shape uses it");
        }
    }
    if out.triangles.is_empty() && out.spheres.is_empty() {
        // With shapes present, their geometry came to nothing (OBJ files without faces, with
        // lines only, or only zero-area triangles): the warnings say which and why.
        let msg = if raw.shapes.is_empty() {
            "the scene has no primitives: add a [[shapes]] table with geometry".to_string()
        } else {
            let why: Vec<String> = cx
                .warnings
                .iter()
                .filter(|w| w.contains("OBJ"))
                .map(|w| format!("\n  {w}"))
                .collect();
            format!(
                "the scene has no primitives: its shapes gave no triangles or spheres{}",
                if why.is_empty() {
                    String::new()
                } else {
                    format!(", because:{}", why.concat())
                }
            )
        };
        return Err(match raw.shapes.first() {
            Some(s) => cx.err(s.span().or(s.value.material.span()), "shapes", msg),
            None => cx.err(None, "shapes", msg),
        });
    }
    if out.emitters.is_empty() && environment == Vec3::ZERO {
        cx.warnings.push(format!(
            "warning: {}: the scene has no emitter and a black environment: every image will be black",
            cx.file
        ));
    }

    Ok(Scene {
        path: path.to_path_buf(),
        camera,
        width,
        height,
        integrator,
        materials,
        material_names,
        emitters: out.emitters,
        triangles: out.triangles,
        spheres: out.spheres,
        environment,
        warnings: std::mem::take(&mut cx.warnings),
    })
}

fn camera(cx: &Cx, c: &RawCamera) -> Result<Camera, SceneError> {
    let position = cx.v3(&c.position, "camera.position")?;
    let target = cx.v3(&c.target, "camera.target")?;
    let up = match &c.up {
        Some(u) => cx.v3(u, "camera.up")?,
        None => Vec3::Y,
    };
    let fov = cx.finite(c.fov_y.span(), "camera.fov_y", c.fov_y.value)?;
    if !(fov > 0.0 && fov < 180.0) {
        let msg = format!(
            "{} is out of range: the vertical field of view in degrees must be in (0, 180)",
            fmt_num(fov)
        );
        return Err(cx.err(c.fov_y.span(), "camera.fov_y", msg));
    }
    let diff = target - position;
    if !diff.is_finite() {
        let msg = format!(
            "target - position = {target} - {position} overflows single precision (beyond about 3.4e38)"
        );
        return Err(cx.err(c.target.span(), "camera.target", msg));
    }
    // Scaled before normalizing: a distance beyond about 1.8e19 would overflow the squared
    // length, and one below about 1e-19 underflow it.
    let dir = crate::robust::normalize_scaled(diff);
    if dir == Vec3::ZERO {
        let msg = format!("the target equals the position {position}: no viewing direction");
        return Err(cx.err(c.target.span(), "camera.target", msg));
    }
    let up_span = c.up.as_ref().and_then(|u| u.span()).or(c.target.span());
    let upn = crate::robust::normalize_scaled(up);
    if upn == Vec3::ZERO {
        return Err(cx.err(up_span, "camera.up", "the up vector has zero length"));
    }
    if dir.cross(upn).length() < 1e-4 {
        let msg = format!(
            "up {up} is parallel to the viewing direction {}",
            target - position
        );
        return Err(cx.err(up_span, "camera.up", msg));
    }
    Ok(Camera {
        position,
        target,
        up,
        fov_y_deg: fov,
    })
}

#[derive(Default)]
struct Shapes {
    triangles: Vec<Triangle>,
    spheres: Vec<Sphere>,
    emitters: Vec<Emitter>,
}

fn shape_primitives(
    cx: &mut Cx,
    f: &str,
    shape: &Sp<RawShape>,
    material: u32,
    out: &mut Shapes,
) -> Result<(), SceneError> {
    let s = &shape.value;
    let label = match &s.name {
        Some(n) => format!("shape '{n}'"),
        None => format!("shape {f}"),
    };

    // Exactly one geometry kind.
    let kinds: Vec<(&str, Option<Range<usize>>)> = [
        s.quads.as_ref().map(|q| ("quads", q.span())),
        s.triangles.as_ref().map(|q| ("triangles", q.span())),
        s.sphere
            .as_ref()
            .map(|q| ("sphere", q.span().or(q.value.radius.span()))),
        s.obj.as_ref().map(|q| ("obj", q.span())),
    ]
    .into_iter()
    .flatten()
    .collect();
    match kinds.as_slice() {
        [] => {
            let msg = format!(
                "{label} has no geometry: give exactly one of quads, triangles, sphere, obj"
            );
            return Err(cx.err(shape.span().or(s.material.span()), f, msg));
        }
        [_] => {}
        [(a, _), (b, span), ..] => {
            let msg =
                format!("{label} has both {a} and {b}: give exactly one geometry kind per shape");
            return Err(cx.err(span.clone(), &format!("{f}.{b}"), msg));
        }
    }
    if let Some(t) = &s.transform {
        if s.obj.is_none() {
            let msg = "transform applies only to obj shapes (write quads, triangles and spheres in world space)";
            let span = t.span().or(shape.span());
            return Err(cx.err(span, &format!("{f}.transform"), msg));
        }
    }

    let emitter = match &s.emission {
        Some(e) => {
            let radiance = cx.radiance(e, &format!("{f}.emission"))?;
            if radiance == Vec3::ZERO {
                None
            } else {
                out.emitters.push(Emitter { radiance });
                Some(out.emitters.len() as u32 - 1)
            }
        }
        None => None,
    };

    let tri = |v: [Vec3; 3]| Triangle {
        v,
        n: None,
        uv: None,
        material,
        emitter,
    };
    if let Some(quads) = &s.quads {
        if quads.value.is_empty() {
            let msg = format!("{label}: the list of quads is empty");
            return Err(cx.err(quads.span(), &format!("{f}.quads"), msg));
        }
        for (k, q) in quads.value.iter().enumerate() {
            let fq = format!("{f}.quads[{k}]");
            let mut p = [Vec3::ZERO; 4];
            for (j, v) in q.value.iter().enumerate() {
                p[j] = cx.vec3(q.span(), &fq, *v)?;
            }
            for (half, idx) in [[0, 1, 2], [0, 2, 3]].iter().enumerate() {
                let t = [p[idx[0]], p[idx[1]], p[idx[2]]];
                if let Some(msg) = edge_overflow(&t) {
                    return Err(cx.err(q.span(), &fq, format!("{label}, quad {k}: {msg}")));
                }
                if degenerate(&t) {
                    let msg = format!(
                        "{label}, quad {k}: its {} triangle (v{}, v{}, v{}) has zero area \
                         (collinear or repeated vertices)",
                        ["first", "second"][half],
                        idx[0],
                        idx[1],
                        idx[2]
                    );
                    return Err(cx.err(q.span(), &fq, msg));
                }
                out.triangles.push(tri(t));
            }
        }
    }
    if let Some(tris) = &s.triangles {
        if tris.value.is_empty() {
            let msg = format!("{label}: the list of triangles is empty");
            return Err(cx.err(tris.span(), &format!("{f}.triangles"), msg));
        }
        for (k, q) in tris.value.iter().enumerate() {
            let ft = format!("{f}.triangles[{k}]");
            let mut t = [Vec3::ZERO; 3];
            for (j, v) in q.value.iter().enumerate() {
                t[j] = cx.vec3(q.span(), &ft, *v)?;
            }
            if let Some(msg) = edge_overflow(&t) {
                return Err(cx.err(q.span(), &ft, format!("{label}, triangle {k}: {msg}")));
            }
            if degenerate(&t) {
                let msg =
                    format!("{label}, triangle {k} has zero area (collinear or repeated vertices)");
                return Err(cx.err(q.span(), &ft, msg));
            }
            out.triangles.push(tri(t));
        }
    }
    if let Some(sp) = &s.sphere {
        let r = &sp.value;
        let center = cx.v3(&r.center, &format!("{f}.sphere.center"))?;
        let fr = format!("{f}.sphere.radius");
        let radius = cx.finite(r.radius.span(), &fr, r.radius.value)?;
        if radius <= 0.0 {
            let msg = format!(
                "{} is out of range: the radius must be > 0",
                fmt_num(radius)
            );
            return Err(cx.err(r.radius.span(), &fr, msg));
        }
        out.spheres.push(Sphere {
            center,
            radius,
            material,
            emitter,
            inward: r.inward,
        });
    }
    if let Some(obj) = &s.obj {
        let xf = match &s.transform {
            Some(t) => transform(cx, f, &t.value)?,
            None => Transform::identity(),
        };
        let mesh = ObjShape {
            field: format!("{f}.obj"),
            label,
            material,
            emitter,
        };
        obj_triangles(cx, &mesh, obj, &xf, &mut out.triangles)?;
    }
    Ok(())
}

/// `p' = translate + R_y(angle) · (scale ⊙ p)`; normals `n' = normalize(R_y · (n / scale))`.
struct Transform {
    translate: Vec3,
    scale: Vec3,
    cos: f32,
    sin: f32,
}

impl Transform {
    fn identity() -> Self {
        Transform {
            translate: Vec3::ZERO,
            scale: Vec3::ONE,
            cos: 1.0,
            sin: 0.0,
        }
    }
    /// Rotation about +y, counter-clockwise seen from above (+z turns toward +x).
    fn rot(&self, p: Vec3) -> Vec3 {
        Vec3::new(
            self.cos * p.x + self.sin * p.z,
            p.y,
            -self.sin * p.x + self.cos * p.z,
        )
    }
    fn point(&self, p: Vec3) -> Vec3 {
        self.translate + self.rot(self.scale * p)
    }
    fn normal(&self, n: Vec3) -> Vec3 {
        self.rot(n / self.scale).normalize_or_zero()
    }
}

fn transform(cx: &Cx, f: &str, t: &RawTransform) -> Result<Transform, SceneError> {
    let mut xf = Transform::identity();
    if let Some(v) = &t.translate {
        xf.translate = cx.v3(v, &format!("{f}.transform.translate"))?;
    }
    if let Some(s) = &t.scale {
        let fs = format!("{f}.transform.scale");
        xf.scale = cx.vec3(s.span(), &fs, s.value.0)?;
        if xf.scale.min_element() <= 0.0 {
            let msg = format!(
                "{} is out of range: every scale factor must be > 0 (a mirror would turn the mesh inside out)",
                fmt_vec(xf.scale)
            );
            return Err(cx.err(s.span(), &fs, msg));
        }
    }
    if let Some(a) = &t.rotate_y_deg {
        let deg = cx.finite(a.span(), &format!("{f}.transform.rotate_y_deg"), a.value)?;
        let rad = (deg as f64).to_radians();
        xf.cos = rad.cos() as f32;
        xf.sin = rad.sin() as f32;
    }
    Ok(xf)
}

/// Checks the face indices of an OBJ text line by line (tobj reports no line numbers, and
/// some malformed relative indices make its index arithmetic overflow). Returns whether the
/// file refers to MTL materials.
fn scan_obj(text: &str) -> Result<bool, (usize, String)> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    let mut uses_mtl = false;
    for (l, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let kw = words.next();
        // tobj reports malformed numbers without a line ("position parse error"): check them.
        if let Some((what, min, max)) = match kw {
            Some("v") => Some(("vertex position", 3, 6)),
            Some("vt") => Some(("texture coordinate", 1, 3)),
            Some("vn") => Some(("normal", 3, 3)),
            _ => None,
        } {
            let nums: Vec<&str> = line.split_whitespace().skip(1).collect();
            if nums.len() < min || nums.len() > max {
                let want = if min == max {
                    format!("{min}")
                } else {
                    format!("{min} to {max}")
                };
                return Err((
                    l + 1,
                    format!("a {what} needs {want} numbers, found {}", nums.len()),
                ));
            }
            if let Some(bad) = nums.iter().find(|x| x.parse::<f32>().is_err()) {
                return Err((l + 1, format!("{what}: '{bad}' is not a number")));
            }
        }
        match kw {
            Some("v") => nv += 1,
            Some("vt") => nt += 1,
            Some("vn") => nn += 1,
            Some("mtllib") | Some("usemtl") => uses_mtl = true,
            Some(kw @ ("f" | "l")) => {
                let mut count = 0;
                for w in words {
                    count += 1;
                    let parts: Vec<&str> = w.split('/').collect();
                    if parts.len() > 3 {
                        return Err((l + 1, format!("'{w}' has more than three indices")));
                    }
                    let kinds = [("vertex", nv), ("texture coordinate", nt), ("normal", nn)];
                    for (p, (kind, n)) in parts.iter().zip(kinds) {
                        if p.is_empty() && kind != "vertex" {
                            continue;
                        }
                        let i: i64 = p
                            .parse()
                            .map_err(|_| (l + 1, format!("'{w}': '{p}' is not an index")))?;
                        let ok = if i > 0 { i <= n } else { i < 0 && n + i >= 0 };
                        if !ok {
                            let msg = format!(
                                "'{w}': {kind} index {i} does not exist ({n} defined before this line; \
                                 indices start at 1, negative ones count back)"
                            );
                            return Err((l + 1, msg));
                        }
                    }
                }
                if kw == "f" && count < 3 {
                    return Err((
                        l + 1,
                        format!("a face needs at least 3 vertices, found {count}"),
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(uses_mtl)
}

/// What an OBJ shape's triangles get, and how its messages name it.
struct ObjShape {
    field: String,
    label: String,
    material: u32,
    emitter: Option<u32>,
}

fn obj_triangles(
    cx: &mut Cx,
    shape: &ObjShape,
    obj: &Sp<String>,
    xf: &Transform,
    out: &mut Vec<Triangle>,
) -> Result<(), SceneError> {
    let fo = shape.field.as_str();
    let span = obj.span();
    let rel = Path::new(&obj.value);
    let full = if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        cx.dir.join(rel)
    };
    let shown = full.display().to_string();
    let text = std::fs::read_to_string(&full).map_err(|e| {
        cx.err(
            span.clone(),
            fo,
            format!("cannot read OBJ file '{shown}': {e}"),
        )
    })?;
    let uses_mtl = scan_obj(&text).map_err(|(line, msg)| {
        cx.err(
            span.clone(),
            fo,
            format!("OBJ file '{shown}', line {line}: {msg}"),
        )
    })?;
    if uses_mtl {
        let msg = format!("OBJ file '{shown}' refers to MTL materials; they are ignored: every face uses this shape's material");
        cx.warn(span.clone(), fo, msg);
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // The MTL loader refuses every library: the scene file assigns the material.
    let loaded = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .map(|(models, _)| models)
    });
    let models = match loaded {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => {
            return Err(cx.err(span, fo, format!("cannot parse OBJ file '{shown}': {e}")))
        }
        Err(_) => {
            return Err(cx.err(
                span,
                fo,
                format!("cannot parse OBJ file '{shown}': malformed content"),
            ))
        }
    };

    let start = out.len();
    let (mut skipped, mut dropped_normals, mut flipped) = (0usize, 0usize, 0usize);
    for model in &models {
        let m = &model.mesh;
        let nverts = m.positions.len() / 3;
        let has_n = !m.normals.is_empty() && m.normals.len() == 3 * nverts;
        let has_uv = !m.texcoords.is_empty() && m.texcoords.len() == 2 * nverts;
        if !m.normals.is_empty() && !has_n {
            let msg = format!(
                "OBJ file '{shown}', object '{}': only some vertices have normals; all are ignored",
                model.name
            );
            cx.warn(span.clone(), fo, msg);
        }
        if !m.texcoords.is_empty() && !has_uv {
            let msg = format!(
                "OBJ file '{shown}', object '{}': only some vertices have texture coordinates; all are ignored",
                model.name
            );
            cx.warn(span.clone(), fo, msg);
        }
        for (t, face) in m.indices.chunks_exact(3).enumerate() {
            let mut v = [Vec3::ZERO; 3];
            let mut n = [Vec3::ZERO; 3];
            let mut uv = [Vec2::ZERO; 3];
            for j in 0..3 {
                let i = face[j] as usize;
                let Some(p) = m.positions.get(3 * i..3 * i + 3) else {
                    return Err(cx.err(
                        span,
                        fo,
                        format!("OBJ file '{shown}': vertex index out of range"),
                    ));
                };
                let p = Vec3::new(p[0], p[1], p[2]);
                if !p.is_finite() {
                    let msg = format!(
                        "OBJ file '{shown}', object '{}', triangle {t}: vertex {p} is not finite",
                        model.name
                    );
                    return Err(cx.err(span, fo, msg));
                }
                v[j] = xf.point(p);
                if !v[j].is_finite() {
                    let msg = format!(
                        "OBJ file '{shown}': the transform moves vertex {p} out of the single-precision range"
                    );
                    return Err(cx.err(span, fo, msg));
                }
                if has_n {
                    n[j] = xf.normal(Vec3::new(
                        m.normals[3 * i],
                        m.normals[3 * i + 1],
                        m.normals[3 * i + 2],
                    ));
                }
                if has_uv {
                    uv[j] = Vec2::new(m.texcoords[2 * i], m.texcoords[2 * i + 1]);
                }
            }
            if let Some(msg) = edge_overflow(&v) {
                let msg = format!(
                    "OBJ file '{shown}', object '{}', triangle {t}: {msg}",
                    model.name
                );
                return Err(cx.err(span, fo, msg));
            }
            if degenerate(&v) {
                skipped += 1;
                continue;
            }
            let mut normals = None;
            if has_n {
                if n.iter().all(|x| x.is_finite() && *x != Vec3::ZERO) {
                    let g = crate::robust::triangle_normal(&v);
                    if (n[0] + n[1] + n[2]).dot(g) < 0.0 {
                        flipped += 1;
                    }
                    normals = Some(n);
                } else {
                    dropped_normals += 1;
                }
            }
            let uv = (has_uv && uv.iter().all(|x| x.is_finite())).then_some(uv);
            out.push(Triangle {
                v,
                n: normals,
                uv,
                material: shape.material,
                emitter: shape.emitter,
            });
        }
    }
    if skipped > 0 {
        cx.warn(
            span.clone(),
            fo,
            format!("OBJ file '{shown}': skipped {skipped} zero-area triangle(s)"),
        );
    }
    if dropped_normals > 0 {
        let msg = format!(
            "OBJ file '{shown}': {dropped_normals} triangle(s) have zero or invalid vertex normals; \
             they use the geometric normal"
        );
        cx.warn(span.clone(), fo, msg);
    }
    if flipped > 0 {
        let msg = format!(
            "OBJ file '{shown}': {flipped} triangle(s) have vertex normals opposite to their winding \
             (the front side follows the counter-clockwise winding)"
        );
        cx.warn(span.clone(), fo, msg);
    }
    if out.len() == start {
        cx.warn(
            span,
            fo,
            format!(
                "{}: OBJ file '{shown}' contains no usable triangles",
                shape.label
            ),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn obj_scan_checks_indices() {
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf -3 -2 -1\n"),
            Ok(false)
        );
        assert_eq!(scan_obj("v 0 0 0\nf 1 2 3\n").unwrap_err().0, 2);
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2 3\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n")
                .unwrap_err()
                .0,
            4
        );
        assert_eq!(scan_obj("v 0 0 0\nv 1 0 0\nf 1 2\n").unwrap_err().0, 3);
        assert_eq!(scan_obj("mtllib a.mtl\n"), Ok(true));
    }

    #[test]
    fn transform_rotates_counter_clockwise_from_above() {
        let mut xf = Transform::identity();
        xf.cos = 0.0;
        xf.sin = 1.0;
        assert!((xf.point(Vec3::Z) - Vec3::X).length() < 1e-6);
        xf.scale = Vec3::new(2.0, 1.0, 1.0);
        // A normal of a plane x = y stretched in x: the normal tilts toward y.
        let n = Transform {
            cos: 1.0,
            sin: 0.0,
            ..xf
        }
        .normal(Vec3::new(1.0, -1.0, 0.0));
        assert!((n - Vec3::new(1.0, -2.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn degenerate_triangles() {
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::ZERO, Vec3::Y]));
        assert!(!degenerate(&[Vec3::ZERO, Vec3::X, Vec3::Y]));
        assert!(degenerate(&[Vec3::ZERO, Vec3::X, Vec3::splat(f32::NAN)]));
    }
}
