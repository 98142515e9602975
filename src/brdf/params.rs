//! Reading a material's parameters from its TOML table, with errors that name the file, the
//! line, the material and the field.
//!
//! Each model's `parse` function asks for its parameters by name through [`ParamReader`];
//! [`ParamReader::finish`] then rejects any field the model did not ask for, so a misspelt
//! parameter is an error rather than a silently ignored value.

use glam::Vec3;
use std::collections::{BTreeMap, BTreeSet};
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::{Spanned, Value};

/// A material definition error, already formatted as `file:line: material 'x', field 'y': …`.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ParamError(pub String);

/// Where the material's TOML came from, for messages.
#[derive(Clone, Debug)]
pub struct Origin<'a> {
    /// File name (or `--material` for an inline table on the command line).
    pub file: &'a str,
    /// The whole source text, used to turn byte spans into line numbers.
    pub source: &'a str,
    /// The material's name (`materials.NAME`).
    pub material: &'a str,
    /// Span of the material's table, for errors about the table as a whole.
    pub span: Range<usize>,
    /// The directory a relative [`Kind::File`] parameter is resolved against: the scene file's
    /// directory; `None` for the working directory (an inline `--material`).
    pub dir: Option<&'a Path>,
}

/// Line number (1-based) of a byte offset in `source`.
/// A number for a message: as written for ordinary magnitudes, in scientific notation (three
/// significant digits) when it is very large or very small, so that 1e300 is not printed as
/// three hundred digits.
pub fn fmt_num<T>(x: T) -> String
where
    T: Copy + Into<f64> + std::fmt::Display + std::fmt::LowerExp,
{
    let a: f64 = x.into();
    let a = a.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e7).contains(&a) {
        let s = format!("{x:.2e}");
        // 1.00e300 → 1e300, 2.50e-7 → 2.5e-7.
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    } else {
        format!("{x}")
    }
}

pub fn line_of(source: &str, offset: usize) -> usize {
    let end = offset.min(source.len());
    source.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// An enum a scene file names by string ([`Param::choice`], [`ParamReader::choice_of`]),
/// implemented by [`choice_enum!`].
pub trait Choice: Copy + 'static {
    /// Every variant, in declaration order.
    const ALL: &'static [Self];
    /// The scene-file name of each variant, in the order of [`Choice::ALL`].
    const NAMES: &'static [&'static str];
}

/// Declares, in one block of a model's file (after its struct and enums), what its registry row
/// ([`super::ModelInfo`]) reads besides `parse`:
/// * `survey`: where the survey gives the model (docs/models.md's model table), as `SURVEY`;
/// * `params`: its scene-file parameters, one row each. A row `NAME = rgb(…)`, `scalar(…)`,
///   `choice(…)` or `file(…)`, optionally followed by `.range_text(…)` or `.default_text(…)`,
///   is `const NAME: Param = Param::rgb(…)…;`, and `PARAMS` lists them in row order (the
///   model's parameter tables in its docs, docs/models.md and scenes/README.md are generated from it: `brdf::docs`);
/// * `representative`: the materials `brdf report` measures ([`Representative`]), as
///   `REPRESENTATIVE`;
/// * `record_codes`: the [`choice_enum!`] types whose codes `pack` writes into the GPU record,
///   as `RECORD_CODES` (`brdf::glsl` writes their `#define`s).
macro_rules! declare_model {
    (
        survey: $survey:literal;
        params: {
            $($(#[$meta:meta])* $c:ident = $ctor:ident($($arg:expr),+ $(,)?) $(.$then:ident($($targ:expr),*))*;)+
        }
        representative: $representative:expr;
        record_codes: [$($codes:ident),* $(,)?];
    ) => {
        $($(#[$meta])* const $c: Param = Param::$ctor($($arg),+)$(.$then($($targ),*))*;)+
        /// The scene-file parameters (the table above is generated from them: `brdf::docs`).
        pub const PARAMS: &[Param] = &[$($c),+];
        /// Where the survey gives the model (docs/models.md's model table).
        pub const SURVEY: &str = $survey;
        /// The materials `brdf report` measures.
        pub const REPRESENTATIVE: $crate::brdf::params::Representative = $representative;
        /// `(GLSL #define name, code)` of each enum in the GPU record, one table per enum.
        pub const RECORD_CODES: &[&[(&str, f32)]] = &[$($codes::RECORD_CODES),*];
    };
}

/// The materials `brdf report` measures for a model, at comparable gloss where the model has
/// gloss (its declaration's `representative`).
#[derive(Clone, Copy, Debug)]
pub enum Representative {
    /// One inline material, labelled with the model's name.
    One(&'static str),
    /// The inline material once for each option of a choice parameter, with the option
    /// appended (`…, form = "survey"`), labelled `model (option)`: a new option is measured too.
    EachOption(&'static str, Param),
    /// `(label, inline material)` pairs, written out.
    Listed(&'static [(&'static str, &'static str)]),
}

impl Representative {
    /// `(label, inline material)` of each material, for the model named `model`.
    pub fn materials(&self, model: &str) -> Vec<(String, String)> {
        match *self {
            Representative::One(src) => vec![(model.to_string(), src.to_string())],
            Representative::EachOption(base, param) => {
                let Kind::Choice(options, _) = param.kind else {
                    panic!(
                        "{model}: the representative materials vary `{}`, not a choice",
                        param.name
                    )
                };
                options
                    .iter()
                    .map(|o| {
                        (
                            format!("{model} ({o})"),
                            format!(r#"{base}, {} = "{o}""#, param.name),
                        )
                    })
                    .collect()
            }
            Representative::Listed(list) => list
                .iter()
                .map(|&(l, src)| (l.to_string(), src.to_string()))
                .collect(),
        }
    }
}

/// Declares an enum whose variants a scene file names by string, from one list of
/// `Variant = "scene-file name"` rows: the enum, its [`Choice`] impl (the string → variant
/// lookup of [`ParamReader::choice_of`]), `NAMES` (the options of its [`Param::choice`]) and
/// `name()`. Rows written `Variant = "name" => "GLSL_NAME"` are for an enum the model writes
/// into its GPU record: `code()` is then the variant's position in the list (0.0, 1.0, …) and
/// `RECORD_CODES` pairs each GLSL `#define` name with its code (the model file's
/// `RECORD_CODES` lists these tables; `brdf::glsl` writes the defines).
macro_rules! choice_enum {
    (
        $(#[$meta:meta])*
        pub enum $e:ident {
            $($(#[$vmeta:meta])* $v:ident = $name:literal => $glsl:literal),+ $(,)?
        }
    ) => {
        choice_enum! {
            $(#[$meta])*
            pub enum $e { $($(#[$vmeta])* $v = $name),+ }
        }
        impl $e {
            /// The code in the GPU record: the variant's position in the declaration.
            pub const fn code(self) -> f32 {
                self as u32 as f32
            }
            /// `(GLSL #define name, code)` of every variant.
            pub const RECORD_CODES: &'static [(&'static str, f32)] = &[$(($glsl, $e::$v.code())),+];
        }
    };
    (
        $(#[$meta:meta])*
        pub enum $e:ident {
            $($(#[$vmeta:meta])* $v:ident = $name:literal),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $e {
            $($(#[$vmeta])* $v),+
        }
        impl $e {
            /// The scene-file name of each variant, in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($name),+];
            /// The variant's scene-file name.
            pub const fn name(self) -> &'static str {
                Self::NAMES[self as usize]
            }
        }
        impl $crate::brdf::params::Choice for $e {
            const ALL: &'static [Self] = &[$($e::$v),+];
            const NAMES: &'static [&'static str] = $e::NAMES;
        }
    };
}

/// What a parameter holds and its default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// `[r, g, b]`, or one number for grey.
    Rgb([f32; 3]),
    Scalar(f32),
    /// One of the options, by name.
    Choice(&'static [&'static str], &'static str),
    /// A path to a data file (a measured material's table), required: relative to the scene
    /// file's directory, or to the working directory for an inline `--material`.
    File,
}

/// One parameter of a model, declared once in the model's file (`PARAMS`): the parser reads
/// its default and range from here ([`ParamReader::rgb_of`], [`ParamReader::scalar_of`],
/// [`ParamReader::choice_of`]), the "unknown field" message lists the declared names, and the
/// parameter tables of the model file, docs/models.md and scenes/README.md are generated from it
/// (`brdf::docs`; tests/docs.rs compares them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Param {
    /// The scene-file field name.
    pub name: &'static str,
    pub unit: &'static str,
    pub kind: Kind,
    /// The range the reader enforces (every channel of an RGB); ±∞ for an open side.
    pub min: f32,
    pub max: f32,
    /// The default as the docs write it, where it is not the plain value (`= alpha_x`): the
    /// model's `parse` then supplies it.
    pub default_text: Option<&'static str>,
    /// The range as the docs write it, where the model's `parse` checks more than
    /// [`min`, `max`] (an open end, π/2): the model then checks it with its own message.
    pub range_text: Option<&'static str>,
    /// One line: what it means, with the equation it enters.
    pub meaning: &'static str,
    /// Where the model's `pack` writes the value in the GPU record, for a texture
    /// (`super::textured`); `None` for a parameter that cannot be textured.
    pub slot: Option<super::textured::RecordSlot>,
    /// The range a texture's values are clamped into, where the model accepts less than
    /// [`min`, `max`] (the ranges of `range_text`); `None`: [`min`, `max`].
    pub texel_range: Option<(f32, f32)>,
    /// For a choice whose other options give no function that its default does not (they
    /// rescale a fitted coefficient: Cook–Torrance's `walter` with ks is `survey` with ks/4),
    /// why: `brdf fit` then fits the default option only, where it fits every option of the
    /// other choices ([`ModelSpec::expand`]).
    ///
    /// [`ModelSpec::expand`]: crate::fit::space::ModelSpec::expand
    pub same_family: Option<&'static str>,
}

impl Param {
    const fn new(
        name: &'static str,
        unit: &'static str,
        kind: Kind,
        meaning: &'static str,
    ) -> Param {
        Param {
            name,
            unit,
            kind,
            min: f32::NEG_INFINITY,
            max: f32::INFINITY,
            default_text: None,
            range_text: None,
            meaning,
            slot: None,
            texel_range: None,
            same_family: None,
        }
    }
    /// An RGB parameter with every channel in [`min`, `max`].
    pub const fn rgb(
        name: &'static str,
        unit: &'static str,
        default: [f32; 3],
        range: (f32, f32),
        meaning: &'static str,
    ) -> Param {
        Param::new(name, unit, Kind::Rgb(default), meaning).within(range)
    }
    /// A scalar parameter in [`min`, `max`].
    pub const fn scalar(
        name: &'static str,
        unit: &'static str,
        default: f32,
        range: (f32, f32),
        meaning: &'static str,
    ) -> Param {
        Param::new(name, unit, Kind::Scalar(default), meaning).within(range)
    }
    const fn within(self, (min, max): (f32, f32)) -> Param {
        Param { min, max, ..self }
    }
    /// A choice among named options.
    pub const fn choice(
        name: &'static str,
        options: &'static [&'static str],
        default: &'static str,
        meaning: &'static str,
    ) -> Param {
        Param::new(name, "—", Kind::Choice(options, default), meaning)
    }
    /// A required file parameter ([`Kind::File`]); `what` names the format in the docs' range.
    pub const fn file(name: &'static str, what: &'static str, meaning: &'static str) -> Param {
        Param {
            default_text: Some("required"),
            range_text: Some(what),
            ..Param::new(name, "path", Kind::File, meaning)
        }
    }
    /// The docs' default text, for a default the model's `parse` derives.
    pub const fn default_text(self, text: &'static str) -> Param {
        Param {
            default_text: Some(text),
            ..self
        }
    }
    /// The docs' range text, for a range the model's `parse` checks itself.
    pub const fn range_text(self, text: &'static str) -> Param {
        Param {
            range_text: Some(text),
            ..self
        }
    }
    /// The parameter may be a texture: its value goes to word `word` of the GPU record (three
    /// words for a colour, one for a scalar).
    pub const fn at(self, word: u32) -> Param {
        Param {
            slot: Some(super::textured::RecordSlot::of(&self, word)),
            ..self
        }
    }
    /// The parameter, an angle in degrees, may be a texture: the record holds its cosine and
    /// sine at words `word` and `word + 1`.
    pub const fn angle_at(self, word: u32) -> Param {
        Param {
            slot: Some(super::textured::RecordSlot {
                word,
                mode: super::textured::SlotMode::Angle,
            }),
            ..self
        }
    }
    /// The range a texture's values are clamped into, where the model's `parse` accepts less
    /// than [`min`, `max`] (an open end: the smallest positive float).
    pub const fn texels_in(self, min: f32, max: f32) -> Param {
        Param {
            texel_range: Some((min, max)),
            ..self
        }
    }
    /// The range a texture's values are clamped into.
    pub fn texture_range(&self) -> (f32, f32) {
        self.texel_range.unwrap_or((self.min, self.max))
    }
    /// A choice whose other options give no function its default does not (the field
    /// `same_family`), with the reason.
    pub const fn same_family(self, why: &'static str) -> Param {
        Param {
            same_family: Some(why),
            ..self
        }
    }
}

pub struct ParamReader<'a> {
    origin: Origin<'a>,
    fields: BTreeMap<String, Spanned<Value>>,
    used: BTreeSet<String>,
    warnings: Vec<String>,
    /// The model's declared parameters, once the model is known ([`ParamReader::declare`]).
    declared: &'static [Param],
}

impl<'a> ParamReader<'a> {
    pub fn new(origin: Origin<'a>, fields: BTreeMap<String, Spanned<Value>>) -> Self {
        let mut used = BTreeSet::new();
        used.insert("model".to_string());
        ParamReader {
            origin,
            fields,
            used,
            warnings: Vec::new(),
            declared: &[],
        }
    }

    /// The model's parameter declarations: the "unknown field" message lists their names.
    pub fn declare(&mut self, params: &'static [Param]) {
        self.declared = params;
    }

    /// An RGB parameter with its declared default and range.
    pub fn rgb_of(&mut self, p: &Param) -> Result<Vec3, ParamError> {
        match p.kind {
            Kind::Rgb(d) => self.rgb(p, Vec3::from_array(d)),
            _ => panic!("parameter {} is not declared as RGB", p.name),
        }
    }

    /// An RGB parameter with its declared range and the default `default` the model derives.
    pub fn rgb_or(&mut self, p: &Param, default: Vec3) -> Result<Vec3, ParamError> {
        self.rgb(p, default)
    }

    /// A scalar parameter with its declared default and range.
    pub fn scalar_of(&mut self, p: &Param) -> Result<f32, ParamError> {
        match p.kind {
            Kind::Scalar(d) => self.scalar(p, d),
            _ => panic!("parameter {} is not declared as a scalar", p.name),
        }
    }

    /// A scalar parameter with its declared range and the default `default` the model derives.
    pub fn scalar_or(&mut self, p: &Param, default: f32) -> Result<f32, ParamError> {
        self.scalar(p, default)
    }

    /// A choice parameter with its declared options and default, as the variant of `E` (a
    /// [`choice_enum!`]) it names; the parameter's options are `E::NAMES`.
    pub fn choice_of<E: Choice>(&mut self, p: &Param) -> Result<E, ParamError> {
        match p.kind {
            Kind::Choice(options, d) => {
                assert_eq!(
                    options,
                    E::NAMES,
                    "parameter {}: options are not the enum's",
                    p.name
                );
                let s = self.choice(p.name, options, d)?;
                let i = E::NAMES
                    .iter()
                    .position(|n| *n == s)
                    .expect("one of the options");
                Ok(E::ALL[i])
            }
            _ => panic!("parameter {} is not declared as a choice", p.name),
        }
    }

    /// A file parameter, required: the path as written, resolved against [`Origin::dir`]. Only
    /// its form is checked here (a non-empty string); the model reads the file and reports
    /// what is wrong with it through [`ParamReader::error`].
    pub fn file_of(&mut self, p: &Param) -> Result<PathBuf, ParamError> {
        assert_eq!(p.kind, Kind::File, "parameter {} is not a file", p.name);
        let Some(v) = self.take(p.name).cloned() else {
            return Err(self.error(
                p.name,
                "missing: this model reads its data from a file (file = \"path\")",
            ));
        };
        let s = v.as_str().ok_or_else(|| {
            self.error(
                p.name,
                format!("expected a path as a string, found {}", v.type_str()),
            )
        })?;
        if s.is_empty() {
            return Err(self.error(p.name, "the path is empty"));
        }
        Ok(match self.origin.dir {
            Some(dir) => dir.join(s),
            None => PathBuf::from(s),
        })
    }

    /// `file:line: material 'name', field 'key': msg`.
    pub fn error(&self, key: &str, msg: impl std::fmt::Display) -> ParamError {
        let span = self
            .fields
            .get(key)
            .map(|v| v.span())
            .unwrap_or(self.origin.span.clone());
        ParamError(format!(
            "{}:{}: material '{}', field '{}': {}",
            self.origin.file,
            line_of(self.origin.source, span.start),
            self.origin.material,
            key,
            msg
        ))
    }

    /// Record a warning (printed by the caller) about a legal but suspicious value.
    pub fn warn(&mut self, key: &str, msg: impl std::fmt::Display) {
        let e = self.error(key, msg);
        self.warnings.push(format!("warning: {}", e.0));
    }

    pub fn has(&self, key: &str) -> bool {
        self.fields.contains_key(key)
    }

    fn take(&mut self, key: &str) -> Option<&Value> {
        self.used.insert(key.to_string());
        self.fields.get(key).map(|v| v.get_ref())
    }

    fn number(&self, key: &str, v: &Value) -> Result<f32, ParamError> {
        let x = match v {
            Value::Float(f) => *f,
            Value::Integer(i) => *i as f64,
            Value::Table(_) => {
                return Err(self.error(
                    key,
                    "expected a number, found a table: a texture (`{ texture = \"FILE\" }`) is read only in a scene file, where the material belongs to a surface",
                ))
            }
            other => {
                return Err(self.error(
                    key,
                    format!("expected a number, found {}", other.type_str()),
                ))
            }
        };
        crate::numbers::f32_of(x).map_err(|msg| self.error(key, msg))
    }

    fn check_range(&self, key: &str, x: f32, min: f32, max: f32) -> Result<(), ParamError> {
        if x < min || x > max {
            let range = match (min == f32::NEG_INFINITY, max == f32::INFINITY) {
                (true, true) => String::new(),
                (false, true) => format!(">= {}", fmt_num(min)),
                (true, false) => format!("<= {}", fmt_num(max)),
                (false, false) => format!("in [{}, {}]", fmt_num(min), fmt_num(max)),
            };
            return Err(self.error(
                key,
                format!("{} is out of range: must be {range}", fmt_num(x)),
            ));
        }
        Ok(())
    }

    /// The field `key` converted by `convert`, or `default` when the field is absent.
    fn read<T>(
        &mut self,
        key: &str,
        default: T,
        convert: impl FnOnce(&Self, &Value) -> Result<T, ParamError>,
    ) -> Result<T, ParamError> {
        match self.take(key).cloned() {
            None => Ok(default),
            Some(v) => convert(self, &v),
        }
    }

    /// The scalar `p` in its declared range, or `default` when the field is absent.
    fn scalar(&mut self, p: &Param, default: f32) -> Result<f32, ParamError> {
        let (key, min, max) = (p.name, p.min, p.max);
        self.read(key, default, |r, v| {
            let x = r.number(key, v)?;
            r.check_range(key, x, min, max)?;
            Ok(x)
        })
    }

    /// The RGB triple `p`, `[r, g, b]` (a single number means grey), with every channel in its
    /// declared range, or `default` when the field is absent.
    fn rgb(&mut self, p: &Param, default: Vec3) -> Result<Vec3, ParamError> {
        let (key, min, max) = (p.name, p.min, p.max);
        self.read(key, default, |r, v| {
            let c = match v {
                Value::Array(a) if a.len() == 3 => Vec3::new(
                    r.number(key, &a[0])?,
                    r.number(key, &a[1])?,
                    r.number(key, &a[2])?,
                ),
                Value::Array(a) => {
                    return Err(r.error(
                        key,
                        format!("expected [r, g, b], found an array of {}", a.len()),
                    ))
                }
                other => Vec3::splat(r.number(key, other)?),
            };
            for x in c.to_array() {
                r.check_range(key, x, min, max)?;
            }
            Ok(c)
        })
    }

    /// One of `options`, or `default` when the field is absent.
    pub fn choice(
        &mut self,
        key: &str,
        options: &[&'static str],
        default: &'static str,
    ) -> Result<&'static str, ParamError> {
        self.read(key, default, |r, v| {
            let s = v.as_str().ok_or_else(|| {
                r.error(key, format!("expected a string, found {}", v.type_str()))
            })?;
            options.iter().copied().find(|o| *o == s).ok_or_else(|| {
                r.error(
                    key,
                    format!(
                        "unknown value \"{s}\": expected one of {}",
                        options.join(", ")
                    ),
                )
            })
        })
    }

    /// The fields the model asked for, sorted (`model` aside): for the check that a model reads
    /// exactly the parameters it declares.
    pub fn names_read(&self) -> Vec<&str> {
        self.used
            .iter()
            .map(|s| s.as_str())
            .filter(|k| *k != "model")
            .collect()
    }

    /// Reject fields the model did not read; return the warnings collected.
    pub fn finish(self) -> Result<Vec<String>, ParamError> {
        if let Some(k) = self.fields.keys().find(|k| !self.used.contains(*k)) {
            // The declared names, sorted like the names read, which they equal (tests/docs.rs
            // checks every declared parameter is read).
            let mut known: Vec<&str> = match self.declared {
                [] => self.used.iter().map(|s| s.as_str()).collect(),
                d => d.iter().map(|p| p.name).collect(),
            };
            known.sort_unstable();
            known.retain(|k| *k != "model");
            return Err(self.error(
                k,
                format!(
                    "unknown field for this model (it takes: {})",
                    known.join(", ")
                ),
            ));
        }
        Ok(self.warnings)
    }
}
