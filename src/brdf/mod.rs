//! Reflectance models. One file per model, the same file name and function names as its GLSL
//! twin in `shaders/brdf/`: `src/brdf/ward.rs` ↔ `shaders/brdf/ward.glsl`. A model with parts
//! has a directory of them on both sides: `src/brdf/he/mod.rs` ↔ `shaders/brdf/he.glsl`, and
//! `src/brdf/he/series.rs` ↔ `shaders/brdf/he/series.glsl` for each part.
//!
//! Every model exposes the same small interface ([`Brdf`]): `eval`, `sample` and `pdf` in the
//! local shading frame, plus `pack` to write its parameters into the GPU material record. The
//! integrators never know which model they hold.
//!
//! Conventions (those of Walter et al. 2007 and pbrt):
//! * local frame: z = shading normal, x = tangent (anisotropy axis), y = bitangent;
//! * `wi` points toward the light, `wo` toward the viewer, both away from the surface;
//! * `eval` returns f_r in sr⁻¹ *without* the cosine;
//! * `sample(given, …)` samples the other direction; the path tracer passes the viewer
//!   direction as `given` and receives `wi`; `pdf(given, sampled)` is the solid-angle density of
//!   that sample (the mixture density over all non-delta lobes, times their selection
//!   probability).
//!
//! Adding a model: a Rust file here (with `parse` and a `declare_model!` block, whose `PARAMS`,
//! `SURVEY`, `REPRESENTATIVE` and `RECORD_CODES` the registry row reads), a GLSL file in
//! `shaders/brdf/` (with `<name>_eval`, `<name>_pdf` and `<name>_sample`), one line in the
//! `registry!` list below and `tests/brdf_<name>.rs`. The megakernel's dispatch and the record
//! codes are generated ([`glsl`]), the parameter tables too ([`docs`]); what cannot be derived (a
//! GPU parity material, a stress generator, a sphere in `scenes/lineup.toml`, the docs' table rows)
//! fails a coverage test that names the model (tests/model_registry.rs, tests/brdf_gpu_parity.rs,
//! tests/docs.rs). A model whose parameter is a data file (`measured`, a MERL table, which cannot
//! be shipped) has its representative material name a file that [`write_fixtures`] writes; the
//! coverage tests build its instances from those files, and `brdf fit`'s lineup (not
//! `scenes/lineup.toml`, whose spheres are parameter-only) shows it.

/// Implements [`Brdf`] for a model type by forwarding `eval`, `pdf` and `sample` to the free
/// functions of the model's file, which carry the names and arguments of its GLSL twin
/// (`ward::eval` ↔ `ward_eval`); the methods written in the braces (`pack`, and `defines` or
/// `scatters` where the defaults do not fit) complete the impl.
macro_rules! impl_brdf {
    ($model:ty { $($methods:tt)* }) => {
        impl $crate::brdf::Brdf for $model {
            fn eval(&self, wi: glam::Vec3, wo: glam::Vec3) -> glam::Vec3 {
                eval(self, wi, wo)
            }
            fn pdf(&self, given: glam::Vec3, sampled: glam::Vec3) -> f32 {
                pdf(self, given, sampled)
            }
            fn sample(
                &self,
                given: glam::Vec3,
                u_lobe: f32,
                u: glam::Vec2,
            ) -> Option<$crate::brdf::BrdfSample> {
                sample(self, given, u_lobe, u)
            }
            fn as_any(&self) -> &dyn std::any::Any {
                self
            }
            $($methods)*
        }
    };
}

pub mod common;
pub mod docs;
pub mod glsl;
pub mod inline;
#[macro_use]
pub mod params;
pub mod textured;
pub mod validate;

use glam::{Vec2, Vec3, Vec4};
pub use params::{Kind, Origin, Param, ParamError, ParamReader, Representative};
use std::fmt::Debug;
use std::sync::Arc;

/// The result of sampling a BRDF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrdfSample {
    /// The sampled direction (toward the light when the viewer direction was given).
    pub wi: Vec3,
    /// f·cosθ/pdf for a non-delta lobe; the lobe's reflectance divided by its selection
    /// probability for a delta lobe.
    pub weight: Vec3,
    /// Solid-angle pdf of `wi` (what [`Brdf::pdf`] returns); 0 for a delta lobe.
    pub pdf: f32,
    /// The sample came from a delta (mirror) lobe: no pdf, no MIS, no NEE.
    pub delta: bool,
}

impl BrdfSample {
    /// A sample of a delta mirror lobe (Cook–Torrance below its mirror roughness, He's specular
    /// lobe, Schlick's mirror): wi = reflect_z(given), no pdf, and `weight` the lobe's
    /// reflectance divided by the probability of choosing it. GLSL: `sample_mirror`.
    pub fn mirror(given: Vec3, weight: Vec3) -> BrdfSample {
        BrdfSample {
            wi: common::reflect_z(given),
            weight,
            pdf: 0.0,
            delta: true,
        }
    }

    /// The common end of sampling a non-delta lobe, as every model's `sample` ends: refuse a
    /// direction below the horizon or with zero density, otherwise weight = f·cosθ / pdf with the
    /// pdf of the whole mixture (`pdf`) and the BRDF (`f`) evaluated at `wi`. The GLSL side ends
    /// each `<model>_sample` with the same three steps.
    pub fn scattered(
        wi: Vec3,
        pdf: impl FnOnce(Vec3) -> f32,
        f: impl FnOnce(Vec3) -> Vec3,
    ) -> Option<Self> {
        if wi.z <= 0.0 {
            return None;
        }
        let p = pdf(wi);
        if p <= 0.0 {
            return None;
        }
        Some(BrdfSample {
            wi,
            weight: f(wi) * (wi.z / p),
            pdf: p,
            delta: false,
        })
    }
}

/// Number of 32-bit words in a GPU material record (`struct Material` in `shaders/common.glsl`).
pub const RECORD_WORDS: usize = 32;
/// Words 0..4 are the header (model index, queue slot, flags, reserved); 4..32 the parameters.
pub const RECORD_PARAMS: usize = RECORD_WORDS - 4;

/// A material's parameters as the GPU reads them: `vec4 p[7]` in GLSL. Each model's Rust
/// `pack` and GLSL accessors agree on the offsets; each model file documents its layout.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Params(pub [f32; RECORD_PARAMS]);

impl Params {
    /// The record from its vec4s in GLSL order (`p[0]`, `p[1]`, …), so that a model's `pack`
    /// reads like the layout its file documents; the vec4s not given are zero.
    pub fn from_vec4s<const N: usize>(p: [Vec4; N]) -> Params {
        const { assert!(4 * N <= RECORD_PARAMS, "a material record holds 7 vec4s") };
        let mut record = Params::default();
        for (slot, v) in record.0.chunks_exact_mut(4).zip(p) {
            slot.copy_from_slice(&v.to_array());
        }
        record
    }
}

/// A yes/no parameter as the GPU record stores it: 1 or 0.
pub fn flag(yes: bool) -> f32 {
    if yes {
        1.0
    } else {
        0.0
    }
}

pub trait Brdf: Debug + Send + Sync {
    /// f_r(wi, wo) in the local frame, without the cosine. Zero below either horizon.
    fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3;
    /// Solid-angle pdf of sampling `sampled` given `given` (0 for directions only a delta lobe
    /// produces).
    fn pdf(&self, given: Vec3, sampled: Vec3) -> f32;
    /// Sample a direction given the other one. `u_lobe` chooses a lobe, `u` the direction.
    /// `None` when the sample carries no energy (below the horizon, zero pdf).
    fn sample(&self, given: Vec3, u_lobe: f32, u: Vec2) -> Option<BrdfSample>;
    /// `(eval(wi, wo), pdf(wo, wi))`: what a light sample's contribution and MIS weight need.
    /// The same two values; a model overrides it where the two share work.
    fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Vec3, f32) {
        (self.eval(wi, wo), self.pdf(wo, wi))
    }
    /// The GPU parameter block.
    fn pack(&self) -> Params;
    /// The model's own type, for tools that translate a material to another renderer (the
    /// bench's Mitsuba peer).
    fn as_any(&self) -> &dyn std::any::Any;
    /// `#define`s this material needs in its model's shade pipeline (features the scene does
    /// not use are compiled out). The union over a model's materials is compiled.
    fn defines(&self) -> Vec<&'static str> {
        Vec::new()
    }
    /// Whether the surface scatters at all (a black Lambert light surface does not); paths
    /// that hit a non-scattering surface end there without a shade dispatch.
    fn scatters(&self) -> bool {
        true
    }
    /// The measured material (its table and sampling lobe), for the GPU upload of its table;
    /// `None` for the analytic models.
    fn measured(&self) -> Option<&measured::Measured> {
        None
    }
    /// The same material with the values `v` of its textured parameters at one point, built
    /// as the model's parser builds it (derived quantities recomputed): [`textured`]. GLSL
    /// twin: `<model>_textured` after the values are written into the record.
    fn with_params(&self, v: &textured::ParamValues) -> Arc<dyn Brdf>;
    /// Where the value of parameter `p` goes in this material's GPU record, for a texture
    /// (the declared slot; a model whose record depends on other parameters overrides it).
    /// `None`: this material's record does not hold `p` (Cook–Torrance's `eta` with
    /// dielectric Fresnel), and its shaders never read it.
    fn record_slot(&self, p: &Param) -> Option<textured::RecordSlot> {
        p.slot
    }
    /// The `#define`s this material needs when the parameters `textured` vary over the
    /// surface: its own, and those a textured parameter may call for anywhere (Ward's
    /// anisotropy for a textured `alpha_x`).
    fn textured_defines(&self, textured: &[&str]) -> Vec<&'static str> {
        let _ = textured;
        self.defines()
    }
}

/// A model of the survey: its registry row. Everything a model needs besides its two twin
/// files and its test file is derived from these rows: the megakernel's dispatch
/// ([`glsl::any_glsl`]), the record codes GLSL compares against ([`glsl::record_glsl`]), the
/// parser's defaults and ranges, the documentation tables ([`docs`]), the `brdf report`
/// materials and the coverage tests.
pub struct ModelInfo {
    /// Scene-file `model = "…"` name, Rust module name and GLSL file stem (`shaders/brdf/NAME.glsl`);
    /// the GLSL functions are `NAME_eval`, `NAME_pdf` and `NAME_sample`.
    pub name: &'static str,
    pub parse: fn(&mut ParamReader) -> Result<Arc<dyn Brdf>, ParamError>,
    /// The scene-file parameters (the model file's `PARAMS`).
    pub params: &'static [Param],
    /// Where the survey gives the model: section and equation numbers (the model file's
    /// `SURVEY`).
    pub survey: &'static str,
    /// The materials `brdf report` measures: the model's variants at comparable gloss (the
    /// model file's `REPRESENTATIVE`; [`ModelInfo::report_materials`] lists them).
    pub representative: Representative,
    /// The float codes of the enums the model writes into its GPU record, as GLSL `#define`s
    /// (`WARD_VARIANT_DUER2006`): the model file's `RECORD_CODES`, one table per enum (each a
    /// [`choice_enum!`]'s `RECORD_CODES`, whose `code()` its `pack` uses).
    pub record_codes: &'static [&'static [(&'static str, f32)]],
}

impl ModelInfo {
    /// `(label, inline material)` of each material `brdf report` measures for this model.
    pub fn report_materials(&self) -> Vec<(String, String)> {
        self.representative.materials(self.name)
    }
    /// Every `(GLSL #define name, code)` of the model's record enums.
    pub fn record_codes(&self) -> impl Iterator<Item = &'static (&'static str, f32)> {
        self.record_codes.iter().flat_map(|t| t.iter())
    }
}

/// The registry row of the model whose module (and scene-file name) is `$m`: its `parse`,
/// `PARAMS`, `SURVEY`, `REPRESENTATIVE` and `RECORD_CODES` (its `declare_model!` block). A model
/// file lacking one fails to compile.
macro_rules! model {
    ($m:ident) => {
        ModelInfo {
            name: stringify!($m),
            parse: $m::parse,
            params: $m::PARAMS,
            survey: $m::SURVEY,
            representative: $m::REPRESENTATIVE,
            record_codes: $m::RECORD_CODES,
        }
    };
}

/// Declares the model modules (`pub mod NAME;`, the file `src/brdf/NAME.rs`), [`MODELS`] and
/// [`MODELS_COUNT`] from the list of model names: a model is one line here.
macro_rules! registry {
    ($($m:ident),* $(,)?) => {
        $(pub mod $m;)*
        /// Number of models in [`MODELS`].
        pub const MODELS_COUNT: usize = [$(stringify!($m)),*].len();
        /// Every model, in a fixed order; the index is the model id on the GPU.
        pub static MODELS: [ModelInfo; MODELS_COUNT] = [$(model!($m)),*];
    };
}

registry!(
    lambert,
    oren_nayar,
    phong,
    blinn_phong,
    cook_torrance,
    he,
    ward,
    schlick,
    measured,
);

/// Writes into `dir` the data files that the models' `REPRESENTATIVE` materials name (relative
/// to `dir`): a measured table is not ours to ship, so the tests, `brdf report` and the docs
/// make a synthetic one. A model whose representative material needs a file writes it here;
/// the registry tests parse every representative material against such a directory.
pub fn write_fixtures(dir: &std::path::Path) -> anyhow::Result<()> {
    measured::write_fixtures(dir)
}

/// A named material instance: which model and its parameters.
#[derive(Clone, Debug)]
pub struct Material {
    /// Index into [`MODELS`].
    pub model: usize,
    pub brdf: Arc<dyn Brdf>,
    /// The back side shades like the front (a scene material's `twosided = true`, read by the
    /// scene loader, not by the model): see `scenes/README.md`.
    pub twosided: bool,
    /// The parameters that vary over the surface, with their textures (`kd = { texture = … }`,
    /// read by the scene loader): `brdf` holds each one's largest value.
    pub textures: Vec<crate::texture::ParamTexture>,
}

impl Material {
    pub fn model_name(&self) -> &'static str {
        MODELS[self.model].name
    }

    /// The BRDF at a surface point of texture coordinates `uv`: `brdf` itself without textures,
    /// else the model with each textured parameter's value there ([`Brdf::with_params`]).
    pub fn at(&self, uv: Vec2) -> Arc<dyn Brdf> {
        if self.textures.is_empty() {
            return self.brdf.clone();
        }
        let values = textured::ParamValues {
            values: self
                .textures
                .iter()
                .map(|t| (t.param.name, t.texture.lookup(uv)))
                .collect(),
        };
        self.brdf.with_params(&values)
    }

    /// The `#define`s the material needs in its model's shade pipeline: the model's own, and
    /// those its textured parameters may call for ([`Brdf::textured_defines`]).
    pub fn defines(&self) -> Vec<&'static str> {
        if self.textures.is_empty() {
            return self.brdf.defines();
        }
        let names: Vec<&str> = self.textures.iter().map(|t| t.param.name).collect();
        self.brdf.textured_defines(&names)
    }
}

/// Parse a material from its fields. Returns the material and any warnings.
pub fn parse_material(
    origin: Origin<'_>,
    fields: std::collections::BTreeMap<String, toml::Spanned<toml::Value>>,
) -> Result<(Material, Vec<String>), ParamError> {
    let mut reader = ParamReader::new(origin, fields);
    let name = match reader.has("model") {
        false => return Err(reader.error("model", "missing: every material names its model")),
        true => reader.choice("model", &model_names(), "lambert")?,
    };
    let model = MODELS
        .iter()
        .position(|m| m.name == name)
        .expect("choice returns a known model");
    reader.declare(MODELS[model].params);
    let brdf = (MODELS[model].parse)(&mut reader)?;
    let warnings = reader.finish()?;
    let twosided = false;
    Ok((
        Material {
            model,
            brdf,
            twosided,
            textures: Vec::new(),
        },
        warnings,
    ))
}

pub fn model_names() -> Vec<&'static str> {
    MODELS.iter().map(|m| m.name).collect()
}

/// Whether parameter `param` of model `model` names a file ([`params::Kind::File`]), which a
/// scene resolves against its own directory.
pub fn is_file_param(model: &str, param: &str) -> bool {
    MODELS
        .iter()
        .filter(|m| m.name == model)
        .flat_map(|m| m.params.iter())
        .any(|p| p.name == param && p.kind == params::Kind::File)
}
