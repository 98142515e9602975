//! The plugin mapping: each supported Mitsuba element turned into the raw form of a TOML scene
//! ([`crate::scene::schema`]), every value spanned with its element, so that the one
//! assembly ([`crate::scene::assemble`]) checks and flattens both formats. The table of what
//! maps to what is in `scenes/README.md` ("Mitsuba 3 XML scenes").

use super::data;
use super::doc::El;
use super::values::{rows, to_world};
use crate::scene::error::SceneError;
use crate::scene::schema::{
    Arr, MaterialTable, RawEnvironment, RawIntegrator, RawLight, RawScene, RawShape, RawSphere,
    RawTransform, Triple,
};
use crate::scene::spanned::{Cx, Sp};
use std::collections::BTreeMap;
use toml::Value;

/// The children of a plugin element by their `name` attribute, each taken at most once; what
/// is left over is an error ([`Props::finish`]), never dropped.
pub(super) struct Props<'e> {
    el: &'e El,
    named: Vec<(&'e El, bool)>,
}

impl<'e> Props<'e> {
    pub(super) fn new(cx: &Cx, el: &'e El) -> Result<Props<'e>, SceneError> {
        let mut names = std::collections::HashSet::new();
        for c in &el.children {
            if let Some(n) = c.attr("name") {
                if !names.insert(n) {
                    let msg = format!("{}: parameter '{n}' given twice", el.describe());
                    return Err(cx.el_err(c, msg));
                }
            }
        }
        let named = el.children.iter().map(|c| (c, false)).collect();
        Ok(Props { el, named })
    }
    /// The child named `name`, if any.
    pub(super) fn take(&mut self, name: &str) -> Option<&'e El> {
        let e = self
            .named
            .iter_mut()
            .find(|(c, _)| c.attr("name") == Some(name))?;
        e.1 = true;
        Some(e.0)
    }
    /// The children with tag `tag` (and any name), e.g. `bsdf`, `ref`, `emitter`.
    pub(super) fn take_tag(&mut self, tag: &str) -> Vec<&'e El> {
        let mut out = Vec::new();
        for e in self
            .named
            .iter_mut()
            .filter(|(c, used)| !used && c.tag == tag)
        {
            e.1 = true;
            out.push(e.0);
        }
        out
    }
    /// Refuse whatever was not taken, naming what the element supports.
    pub(super) fn finish(self, cx: &Cx, supported: &str) -> Result<(), SceneError> {
        if let Some((c, _)) = self.named.iter().find(|(_, used)| !used) {
            let what = match c.attr("name") {
                Some(n) => format!("parameter {} '{n}'", c.tag),
                None => c.describe(),
            };
            let msg = format!(
                "{} does not take {what} (supported: {supported})",
                self.el.describe()
            );
            return Err(cx.el_err(c, msg));
        }
        Ok(())
    }
}

pub(super) fn sp<T>(el: &El, value: T) -> Sp<T> {
    Sp {
        span: Some(el.span.clone()),
        value,
    }
}

impl Cx<'_> {
    fn want_tag(&self, el: &El, tags: &[&str]) -> Result<(), SceneError> {
        if tags.contains(&el.tag.as_str()) {
            return Ok(());
        }
        let msg = format!(
            "parameter '{}' is a <{}>: expected {}",
            el.attr("name").unwrap_or_default(),
            el.tag,
            tags.iter()
                .map(|t| format!("<{t}>"))
                .collect::<Vec<_>>()
                .join(" or ")
        );
        Err(self.el_err(el, msg))
    }
    pub(super) fn float(&self, el: &El) -> Result<f64, SceneError> {
        self.want_tag(el, &["float", "integer"])?;
        self.number(el, self.attr(el, "value")?)
    }
    fn integer(&self, el: &El) -> Result<i64, SceneError> {
        self.want_tag(el, &["integer"])?;
        let t = self.attr(el, "value")?.trim();
        t.parse()
            .map_err(|_| self.el_err(el, format!("<integer>: '{t}' is not a whole number")))
    }
    pub(super) fn bool_of(&self, el: &El) -> Result<bool, SceneError> {
        self.want_tag(el, &["boolean"])?;
        match self.attr(el, "value")?.trim() {
            "true" => Ok(true),
            "false" => Ok(false),
            v => Err(self.el_err(el, format!("<boolean>: '{v}' is neither true nor false"))),
        }
    }
    fn string<'e>(&self, el: &'e El) -> Result<&'e str, SceneError> {
        self.want_tag(el, &["string"])?;
        self.attr(el, "value")
    }
    /// An RGB colour: `<rgb value="r, g, b">` (or one number), or a grey `<float>`.
    pub(super) fn color_of(&self, el: &El) -> Result<[f64; 3], SceneError> {
        self.want_tag(el, &["rgb", "float", "spectrum"])?;
        if el.tag == "spectrum"
            && (el.attr("filename").is_some() || el.attr("value").is_some_and(|v| v.contains(':')))
        {
            return Err(self.el_err(
                el,
                "a <spectrum> of wavelength:value pairs or from a file is not read (brdfwave renders in RGB): write the colour as <rgb>; a constant <spectrum value=\"x\"/> is read",
            ));
        }
        let v = self.numbers(el, self.attr(el, "value")?)?;
        match (el.tag.as_str(), v.as_slice()) {
            (_, [x]) => Ok([*x; 3]),
            ("rgb", [r, g, b]) => Ok([*r, *g, *b]),
            ("spectrum", _) => Err(self.el_err(
                el,
                "<spectrum> is read only as one constant value: write an <rgb> colour",
            )),
            _ => Err(self.el_err(
                el,
                format!(
                    "{}: a colour needs 1 or 3 numbers, found {}",
                    el.describe(),
                    v.len()
                ),
            )),
        }
    }
    /// An emitter's radiance, intensity or irradiance: [`Cx::color_of`], except that a
    /// constant `<spectrum>` is that multiple of the CIE D65 illuminant, as Mitsuba 3 reads a
    /// constant spectrum inside an emitter (so that `<spectrum value="1"/>` emits daylight, not
    /// equal energy); in its RGB variants that is [`D65_SRGB`] per unit. A `<float>` stays
    /// grey, as in Mitsuba.
    pub(super) fn emission_of(&self, el: &El) -> Result<[f64; 3], SceneError> {
        let c = self.color_of(el)?;
        Ok(if el.tag == "spectrum" {
            [0, 1, 2].map(|i| c[i] * D65_SRGB[i])
        } else {
            c
        })
    }
    fn color_value(&self, el: &El) -> Result<Sp<Value>, SceneError> {
        if el.tag == "texture" {
            return texture_value(self, el);
        }
        let c = self.color_of(el)?;
        Ok(sp(
            el,
            Value::Array(c.iter().map(|x| Value::Float(*x)).collect()),
        ))
    }
}

/// The linear sRGB colour of one unit of the CIE D65 illuminant spectrum as Mitsuba 3.9.1's RGB
/// variants evaluate it (the spectrum integrated against the CIE 1931 matching functions,
/// normalised by ∫ȳ, and taken to linear sRGB; read from `mi.traverse` of a constant emitter
/// with `<spectrum name="radiance" value="1"/>`, in f32).
pub(super) const D65_SRGB: [f64; 3] = [
    1.204_793_930_053_711,
    0.948_291_003_704_071,
    0.908_916_056_156_158_4,
];

/// The ids that `<bsdf type="twosided">` elements under `els` name by `<ref>`.
fn twosided_refs<'e>(els: &'e [El], out: &mut Vec<&'e str>) {
    for el in els {
        if el.tag == "bsdf" && el.attr("type") == Some("twosided") {
            let refs = el.children.iter().filter(|c| c.tag == "ref");
            out.extend(refs.filter_map(|r| r.attr("id")));
        }
        twosided_refs(&el.children, out);
    }
}

/// The message for a `<ref id>` that names no BSDF read before it (`known`: those read).
pub(super) fn undefined_ref<'a>(id: &str, known: impl Iterator<Item = &'a String>) -> String {
    let mut known: Vec<&str> = known
        .map(String::as_str)
        .filter(|k| !k.starts_with('('))
        .collect();
    known.sort_unstable();
    format!(
        "<ref id=\"{}\">: no top-level <bsdf id=\"{}\"> in the scene (BSDFs with ids: {}; a twosided BSDF names only one defined before it)",
        crate::errors::excerpt(id),
        crate::errors::excerpt(id),
        if known.is_empty() {
            "none".to_string()
        } else {
            known.join(", ")
        }
    )
}

/// The scene's top-level elements → the raw scene. `width`/`height` default to Mitsuba's
/// 768 × 576, `sample_count` to its 4.
pub(super) fn scene(cx: &mut Cx, top: &[El]) -> Result<RawScene, SceneError> {
    let mut camera = None;
    let mut film = None;
    let mut integrator = RawIntegrator {
        spp: None,
        max_depth: None,
        seed: None,
        russian_roulette: None,
        rr_start_depth: None,
        sampler: None,
        hide_emitters: None,
    };
    let mut environment = None;
    let mut materials: BTreeMap<String, Sp<MaterialTable>> = BTreeMap::new();
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    let mut saw_integrator: Option<&El> = None;
    unique_ids(cx, top)?;
    super::values::rotate_axis_warnings(cx, top);
    super::values::to_uv_warnings(cx, top);
    // The top-level BSDFs first, in their order: a shape may refer to one defined after it, as
    // Mitsuba allows.
    for el in top.iter().filter(|el| el.tag == "bsdf") {
        let Some(id) = el.attr("id") else {
            return Err(cx.el_err(
                el,
                "a top-level <bsdf> needs an id (shapes refer to it with <ref id=\"…\"/>)",
            ));
        };
        let table = bsdf(cx, el, &materials)?;
        if materials.insert(id.to_string(), sp(el, table)).is_some() {
            return Err(cx.el_err(el, format!("a second <bsdf> with id '{id}'")));
        }
    }
    for el in top {
        match (el.tag.as_str(), el.attr("type")) {
            ("sensor", _) => {
                if camera.is_some() {
                    return Err(cx.el_err(el, "a second <sensor>: brdfwave renders one camera"));
                }
                let (c, f) = super::sensor::sensor(cx, el, &mut integrator)?;
                camera = Some(c);
                film = Some(f);
            }
            ("integrator", _) => {
                if let Some(first) = saw_integrator {
                    let msg = format!(
                        "a second <integrator>: brdfwave renders with one (the first is at {})",
                        cx.where_is(first)
                    );
                    return Err(cx.el_err(el, msg));
                }
                saw_integrator = Some(el);
                super::sensor::integrator(cx, el, &mut integrator)?;
            }
            // Read before everything else (below).
            ("bsdf", _) => {}
            ("emitter", Some("constant")) => {
                if environment.is_some() {
                    return Err(cx.el_err(
                        el,
                        "a second environment emitter (constant or envmap): brdfwave has one environment",
                    ));
                }
                let mut p = Props::new(cx, el)?;
                // Mitsuba's default radiance is 1 (grey, as a <float>).
                let radiance = match p.take("radiance") {
                    Some(r) => sp(r, Triple(cx.emission_of(r)?)),
                    None => sp(el, Triple([1.0; 3])),
                };
                p.finish(cx, "radiance")?;
                environment = Some(RawEnvironment {
                    radiance: Some(radiance),
                    map: None,
                    scale: None,
                    transform: None,
                });
            }
            ("emitter", Some("envmap")) => {
                if environment.is_some() {
                    return Err(cx.el_err(
                        el,
                        "a second environment emitter (constant or envmap): brdfwave has one environment",
                    ));
                }
                environment = Some(envmap(cx, el)?);
            }
            ("emitter", Some("point" | "directional")) => lights.push(delta_light(cx, el)?),
            ("emitter", _) => return Err(emitter_error(cx, el, false)),
            ("shape", _) => {
                shapes.push(super::shapes::shape(cx, el, shapes.len(), &mut materials)?)
            }
            _ => {
                let msg = format!(
                    "{} is not supported at the top level (supported: sensor, integrator, bsdf, shape, emitter type=\"constant\" or \"envmap\", include, default)",
                    el.describe()
                );
                return Err(cx.el_err(el, msg));
            }
        }
    }
    let (Some(camera), Some(film)) = (camera, film) else {
        return Err(cx.err(
            None,
            "scene",
            "the scene has no <sensor type=\"perspective\">",
        ));
    };
    if saw_integrator.is_none() {
        super::sensor::default_depth(cx, &mut integrator);
    }
    // A BSDF that a twosided one names by <ref> was copied into it: unless a shape uses it as
    // it is, it is no material of its own (the assembly would warn that no shape uses it).
    let mut wrapped = Vec::new();
    twosided_refs(top, &mut wrapped);
    for id in wrapped {
        if !shapes.iter().any(|s| s.value.material.value == id) {
            materials.remove(id);
        }
    }
    Ok(RawScene {
        camera,
        film,
        integrator: Some(integrator),
        environment,
        materials,
        shapes,
        lights,
    })
}

/// A top-level `envmap` emitter → `[environment]` with a `map`: `filename` (relative to the
/// file that names it), `scale` (default 1) and `to_world` (a rotation, checked by the
/// assembly).
fn envmap(cx: &Cx, el: &El) -> Result<RawEnvironment, SceneError> {
    let mut p = Props::new(cx, el)?;
    let Some(f) = p.take("filename") else {
        return Err(cx.el_err(el, "<emitter type=\"envmap\"> needs a filename"));
    };
    let file = f.dir.join(cx.string(f)?);
    let map = Some(sp(f, file.display().to_string()));
    let scale = match p.take("scale") {
        Some(e) => Some(sp(e, cx.float(e)?)),
        None => None,
    };
    let transform = shape_transform(cx, p.take("to_world"))?;
    p.finish(cx, "filename, scale, to_world")?;
    Ok(RawEnvironment {
        radiance: None,
        map,
        scale,
        transform,
    })
}

/// Every `id` in the scene names one object (Mitsuba's rule): a second element with the same id
/// (two shapes, a shape and a BSDF, ...) is refused, naming both; a `<ref id>` refers, it does
/// not define.
fn unique_ids(cx: &Cx, top: &[El]) -> Result<(), SceneError> {
    fn walk<'e>(
        cx: &Cx,
        els: &'e [El],
        seen: &mut std::collections::HashMap<&'e str, &'e El>,
    ) -> Result<(), SceneError> {
        for el in els {
            if let (Some(id), false) = (el.attr("id"), el.tag == "ref") {
                if let Some(first) = seen.insert(id, el) {
                    let msg = format!(
                        "id '{}' is given twice: to {} here and to {} at {} (an id names one \
                         object)",
                        crate::errors::excerpt(id),
                        el.describe(),
                        first.describe(),
                        cx.where_is(first)
                    );
                    return Err(cx.el_err(el, msg));
                }
            }
            walk(cx, &el.children, seen)?;
        }
        Ok(())
    }
    walk(cx, top, &mut std::collections::HashMap::new())
}

/// A top-level `point` or `directional` emitter → a `[[lights]]` table. A point light's
/// `position` (or its `to_world`'s origin) and `intensity`; a directional light's `direction`
/// (or its `to_world`'s +z) and `irradiance`, as in Mitsuba 3. Missing values are Mitsuba's
/// defaults: at the origin, along +z, of intensity / irradiance 1.
fn delta_light(cx: &Cx, el: &El) -> Result<Sp<RawLight>, SceneError> {
    let kind = cx.attr(el, "type")?;
    let mut p = Props::new(cx, el)?;
    let xf = match p.take("to_world") {
        Some(t) => Some(to_world(cx, t)?.m),
        None => None,
    };
    let (place, power, place_el) = match kind {
        "point" => ("position", "intensity", p.take("position")),
        _ => ("direction", "irradiance", p.take("direction")),
    };
    if place_el.is_some() && xf.is_some() {
        let msg = format!("<emitter type=\"{kind}\">: give either {place} or to_world, not both");
        return Err(cx.el_err(el, msg));
    }
    let v = match (place_el, xf) {
        (Some(e), _) => cx.xyz(e, 0.0)?,
        (None, Some(m)) if kind == "point" => m.transform_point3(glam::DVec3::ZERO).into(),
        (None, Some(m)) => m.transform_vector3(glam::DVec3::Z).into(),
        (None, None) if kind == "point" => [0.0; 3],
        (None, None) => [0.0, 0.0, 1.0],
    };
    let power_value = match p.take(power) {
        Some(e) => sp(e, Triple(cx.emission_of(e)?)),
        None => sp(el, Triple([1.0; 3])),
    };
    p.finish(cx, &format!("{place}, {power}, to_world"))?;
    let at = |x: [f64; 3]| Some(sp(el, Arr(x)));
    let (position, direction, intensity, irradiance) = match kind {
        "point" => (at(v), None, Some(power_value), None),
        _ => (None, at(v), None, Some(power_value)),
    };
    Ok(sp(
        el,
        RawLight {
            kind: sp(el, kind.to_string()),
            position,
            intensity,
            direction,
            irradiance,
        },
    ))
}

/// Why an emitter is refused: a type brdfwave lacks, or an `area` emitter outside a shape.
pub(super) fn emitter_error(cx: &Cx, el: &El, in_shape: bool) -> SceneError {
    match el.attr("type") {
        Some("point" | "directional") if in_shape => cx.el_err(el, format!("an <emitter type=\"{}\"> belongs at the top level, not in a <shape>", el.attr("type").unwrap_or_default())),
        Some("area") if !in_shape => cx.el_err(el, "an <emitter type=\"area\"> belongs inside a <shape>"),
        Some(t @ ("constant" | "envmap")) if in_shape => cx.el_err(el, format!("an <emitter type=\"{t}\"> belongs at the top level, not in a <shape>")),
        _ => cx.el_err(
            el,
            format!(
                "{} is not supported (supported: area inside a shape; constant, envmap, point and directional at the top level)",
                el.describe()
            ),
        ),
    }
}

/// A BSDF element → the material table `brdf::parse_material` reads. `defined`: the top-level
/// BSDFs read so far, which a `twosided` one may name by `<ref id>`.
pub(super) fn bsdf(
    cx: &Cx,
    el: &El,
    defined: &BTreeMap<String, Sp<MaterialTable>>,
) -> Result<MaterialTable, SceneError> {
    let kind = cx.attr(el, "type")?;
    let mut p = Props::new(cx, el)?;
    let mut t = MaterialTable::new();
    let model = |name: &str| sp(el, Value::String(name.to_string()));
    match kind {
        "diffuse" => {
            t.insert("model".into(), model("lambert"));
            take_color(cx, &mut p, &mut t, ("reflectance", "albedo"))?;
            p.finish(cx, "reflectance")?;
        }
        "conductor" | "roughconductor" => {
            microfacet(cx, el, kind == "roughconductor", &mut p, &mut t)?;
            conductor(cx, el, &mut p, &mut t)?;
            p.finish(cx, "material, eta, k, specular_reflectance, and for roughconductor distribution, alpha (or equal alpha_u, alpha_v), sample_visible")?;
        }
        "plastic" | "roughplastic" => {
            microfacet(cx, el, kind == "roughplastic", &mut p, &mut t)?;
            plastic(cx, el, &mut p, &mut t)?;
            p.finish(cx, "diffuse_reflectance, specular_reflectance, int_ior, ext_ior, nonlinear = false, and for roughplastic distribution, alpha, sample_visible")?;
        }
        "twosided" => {
            // One BSDF for both sides, nested or named by a <ref>: the `twosided` flag of a
            // brdfwave material. Mitsuba's second BSDF (a different back side) has no brdfwave
            // form.
            let refs = p.take_tag("ref");
            let inner = p.take_tag("bsdf");
            let (one, table) = match (refs.as_slice(), inner.as_slice()) {
                ([], [inner]) => (*inner, bsdf(cx, inner, defined)?),
                ([r], []) => {
                    let id = cx.attr(r, "id")?;
                    let Some(table) = defined.get(id) else {
                        return Err(cx.el_err(r, undefined_ref(id, defined.keys())));
                    };
                    (*r, table.value.clone())
                }
                _ => {
                    let msg = format!(
                        "<bsdf type=\"twosided\"> needs exactly one BSDF, nested or by <ref> (found {} nested and {} <ref>): brdfwave shades both sides with one material",
                        inner.len(),
                        refs.len()
                    );
                    return Err(cx.el_err(el, msg));
                }
            };
            if table.contains_key("twosided") {
                let msg = "a twosided BSDF inside another <bsdf type=\"twosided\">";
                return Err(cx.el_err(one, msg));
            }
            t = table;
            t.insert("twosided".into(), sp(el, Value::Boolean(true)));
            p.finish(cx, "one nested bsdf or ref")?;
        }
        name if crate::brdf::MODELS.iter().any(|m| m.name == name) => {
            // One of the survey's models by our name: the parameters as the model names them.
            t.insert("model".into(), model(name));
            for c in &el.children {
                let Some(n) = c.attr("name") else {
                    let msg = format!(
                        "{}: {} needs a name (the model's parameter)",
                        el.describe(),
                        c.describe()
                    );
                    return Err(cx.el_err(c, msg));
                };
                let v = match c.tag.as_str() {
                    "float" => sp(c, Value::Float(cx.float(c)?)),
                    "integer" => sp(c, Value::Integer(cx.integer(c)?)),
                    "boolean" => sp(c, Value::Boolean(cx.bool_of(c)?)),
                    // A file (a measured table) is relative to the element's own file.
                    "string" if crate::brdf::is_file_param(name, n) => {
                        let file = c.dir.join(cx.string(c)?);
                        sp(c, Value::String(file.display().to_string()))
                    }
                    "string" => sp(c, Value::String(cx.string(c)?.to_string())),
                    "rgb" | "texture" => cx.color_value(c)?,
                    _ => {
                        let msg = format!("{}: parameter '{n}' is a {}: expected float, integer, boolean, string, rgb or texture", el.describe(), c.describe());
                        return Err(cx.el_err(c, msg));
                    }
                };
                t.insert(n.to_string(), v);
            }
        }
        other => {
            let msg = format!(
                "<bsdf type=\"{other}\"> is not supported (supported: diffuse, conductor, roughconductor, plastic, roughplastic, and the survey's models by name: {})",
                crate::brdf::model_names().join(", ")
            );
            return Err(cx.el_err(el, msg));
        }
    }
    Ok(t)
}

/// A `<texture type="bitmap">` parameter → the TOML texture table (`kd = { texture = … }`):
/// `filename` (relative to the file that names it), `raw`, `filter_type` (`bilinear`,
/// `nearest`), `wrap_mode` (`repeat`, `mirror`, `clamp`) and `to_uv` (its 2-D part, as Mitsuba
/// takes it: rows and columns 0, 1 and 3 of the 4×4 transform).
/// The assembly reads the image and checks the values (`crate::scene::textures`).
fn texture_value(cx: &Cx, el: &El) -> Result<Sp<Value>, SceneError> {
    if el.attr("type") != Some("bitmap") {
        let msg = format!("{} is not supported (supported: bitmap)", el.describe());
        return Err(cx.el_err(el, msg));
    }
    let mut p = Props::new(cx, el)?;
    let Some(f) = p.take("filename") else {
        return Err(cx.el_err(el, "<texture type=\"bitmap\"> needs a filename"));
    };
    let mut t = toml::map::Map::new();
    let file = f.dir.join(cx.string(f)?);
    t.insert("texture".into(), Value::String(file.display().to_string()));
    // Always given: Mitsuba decodes an sRGB image unless `raw`, on a number parameter too,
    // where a texture table's default is the values as stored.
    let raw = match p.take("raw") {
        Some(r) => cx.bool_of(r)?,
        None => false,
    };
    t.insert("raw".into(), Value::Boolean(raw));
    if let Some(x) = p.take("filter_type") {
        t.insert("filter".into(), Value::String(cx.string(x)?.to_string()));
    }
    if let Some(x) = p.take("wrap_mode") {
        t.insert("wrap".into(), Value::String(cx.string(x)?.to_string()));
    }
    if let Some(x) = p.take("to_uv") {
        // (A 3×3 `<matrix>` is the linear part of the 4×4, as Mitsuba reads it: its third
        // column is no (u, v) offset; `to_uv_warnings` says so.)
        let r = rows(&to_world(cx, x)?.m);
        let rows = [[r[0][0], r[0][1], r[0][3]], [r[1][0], r[1][1], r[1][3]]];
        let row = |r: [f64; 3]| Value::Array(r.iter().map(|v| Value::Float(*v)).collect());
        let mut m = toml::map::Map::new();
        m.insert(
            "matrix".into(),
            Value::Array(vec![row(rows[0]), row(rows[1])]),
        );
        t.insert("to_uv".into(), Value::Table(m));
    }
    p.finish(cx, "filename, raw, filter_type, wrap_mode, to_uv")?;
    Ok(sp(el, Value::Table(t)))
}

fn put(t: &mut MaterialTable, el: &El, k: &str, v: Value) {
    t.insert(k.into(), sp(el, v));
}

/// The colour property `from`, when given, as the material's `to`; whether it was given.
fn take_color(
    cx: &Cx,
    p: &mut Props,
    t: &mut MaterialTable,
    (from, to): (&str, &str),
) -> Result<bool, SceneError> {
    let Some(e) = p.take(from) else {
        return Ok(false);
    };
    t.insert(to.into(), cx.color_value(e)?);
    Ok(true)
}

/// The microfacet settings every Mitsuba plugin shares: `distribution` (Beckmann, GGX) and
/// `alpha` (Mitsuba's Beckmann α is the rms slope m, its GGX α ours), with `alpha_u`/`alpha_v`
/// only when equal (our Cook–Torrance is isotropic); a smooth plugin is a delta mirror.
fn microfacet(
    cx: &Cx,
    el: &El,
    rough: bool,
    p: &mut Props,
    t: &mut MaterialTable,
) -> Result<(), SceneError> {
    put(t, el, "model", Value::String("cook_torrance".into()));
    put(t, el, "geometry", Value::String("smith".into()));
    put(t, el, "normalization", Value::String("walter".into()));
    if !rough {
        put(t, el, "roughness", Value::Float(0.0));
        return Ok(());
    }
    if let Some(d) = p.take("distribution") {
        let name = cx.string(d)?;
        if !["beckmann", "ggx"].contains(&name) {
            return Err(cx.el_err(
                d,
                format!("distribution '{name}' is not supported (supported: beckmann, ggx)"),
            ));
        }
        put(t, d, "distribution", Value::String(name.into()));
    }
    let alpha = match (p.take("alpha"), p.take("alpha_u"), p.take("alpha_v")) {
        (Some(a), None, None) if a.tag == "texture" => {
            t.insert("roughness".into(), texture_value(cx, a)?);
            None
        }
        (Some(a), None, None) => Some((a, cx.float(a)?)),
        (None, Some(u), Some(v)) => {
            let (au, av) = (cx.float(u)?, cx.float(v)?);
            if au != av {
                // The values as written (parsed in single precision, they would print widened).
                let (wu, wv) = (cx.attr(u, "value")?, cx.attr(v, "value")?);
                return Err(cx.el_err(v, format!("alpha_u {wu} ≠ alpha_v {wv}: anisotropic roughness is not supported (Cook–Torrance is isotropic; <bsdf type=\"ward\"> is anisotropic)")));
            }
            Some((u, au))
        }
        (None, None, None) => None,
        (_, Some(e), _) | (_, _, Some(e)) => {
            return Err(cx.el_err(e, "give either alpha, or both alpha_u and alpha_v"));
        }
    };
    match alpha {
        Some((a, x)) => put(t, a, "roughness", Value::Float(x)),
        None if t.contains_key("roughness") => {}
        // Mitsuba's default α.
        None => put(t, el, "roughness", Value::Float(0.1)),
    }
    if let Some(s) = p.take("sample_visible") {
        cx.bool_of(s)?;
    }
    Ok(())
}

/// A conductor's Fresnel terms and specular colour (after [`microfacet`]).
fn conductor(cx: &Cx, el: &El, p: &mut Props, t: &mut MaterialTable) -> Result<(), SceneError> {
    put(t, el, "kd", Value::Float(0.0));
    take_color(cx, p, t, ("specular_reflectance", "ks"))?;
    let rgb = |v: [f32; 3]| Value::Array(v.iter().map(|x| Value::Float(*x as f64)).collect());
    match (p.take("material"), p.take("eta"), p.take("k")) {
        (Some(m), None, None) => match cx.string(m)? {
            "none" => {
                put(t, m, "fresnel", Value::String("schlick".into()));
                put(t, m, "f0", Value::Float(1.0));
            }
            name => {
                let Some((eta, k)) = data::metal(name) else {
                    let msg = format!(
                        "unknown conductor material '{name}' (known: none, {})",
                        data::metal_names()
                    );
                    return Err(cx.el_err(m, msg));
                };
                put(t, m, "fresnel", Value::String("conductor".into()));
                put(t, m, "eta", rgb(eta));
                put(t, m, "k", rgb(k));
            }
        },
        (None, Some(eta), k) => {
            put(t, el, "fresnel", Value::String("conductor".into()));
            t.insert("eta".into(), cx.color_value(eta)?);
            // Mitsuba's default κ when only η is given: 1.
            match k {
                Some(k) => {
                    t.insert("k".into(), cx.color_value(k)?);
                }
                None => put(t, el, "k", Value::Float(1.0)),
            }
        }
        // Mitsuba's default: material="none", a perfect mirror (F = 1); and so with κ alone,
        // whose default η of 0 (a purely imaginary index) reflects everything whatever κ is.
        (None, None, _) => {
            put(t, el, "fresnel", Value::String("schlick".into()));
            put(t, el, "f0", Value::Float(1.0));
        }
        (Some(_), Some(e), _) | (Some(_), _, Some(e)) => {
            return Err(cx.el_err(e, "give either material, or eta and k, not both"));
        }
    }
    Ok(())
}

/// A plastic's diffuse base, specular colour and index of refraction (after [`microfacet`]).
fn plastic(cx: &Cx, el: &El, p: &mut Props, t: &mut MaterialTable) -> Result<(), SceneError> {
    put(t, el, "fresnel", Value::String("dielectric".into()));
    if !take_color(cx, p, t, ("diffuse_reflectance", "kd"))? {
        put(t, el, "kd", Value::Float(0.5));
    }
    take_color(cx, p, t, ("specular_reflectance", "ks"))?;
    fn ior<'e>(
        cx: &Cx,
        name: &str,
        default: f64,
        p: &mut Props<'e>,
    ) -> Result<(f64, Option<&'e El>), SceneError> {
        let Some(e) = p.take(name) else {
            return Ok((default, None));
        };
        let v = match e.tag.as_str() {
            "string" => {
                let n = cx.string(e)?;
                data::ior(n).ok_or_else(|| {
                    let known: Vec<&str> = data::IORS.iter().map(|x| x.0).collect();
                    cx.el_err(
                        e,
                        format!(
                            "unknown index of refraction '{n}' (known: {})",
                            known.join(", ")
                        ),
                    )
                })?
            }
            _ => cx.float(e)?,
        };
        Ok((v, Some(e)))
    }
    let (int, int_el) = ior(cx, "int_ior", 1.49, p)?;
    let (ext, ext_el) = ior(cx, "ext_ior", 1.000277, p)?;
    // Each index is checked by its own name before their ratio (the model's `ior`) is formed:
    // ext_ior = 0 made an ior of inf, reported as a field the file does not have.
    for (name, v, e) in [("int_ior", int, int_el), ("ext_ior", ext, ext_el)] {
        if v <= 0.0 {
            let msg = format!("{name} {v} is out of range: an index of refraction is > 0");
            return Err(cx.el_err(e.unwrap_or(el), msg));
        }
    }
    let ratio = crate::numbers::f32_of(int / ext).map_err(|m| {
        let fmt = |x: f64| crate::brdf::params::fmt_num(x as f32);
        let msg = format!("int_ior / ext_ior = {} / {}: {m}", fmt(int), fmt(ext));
        cx.el_err(ext_el.or(int_el).unwrap_or(el), msg)
    })?;
    put(t, int_el.unwrap_or(el), "ior", Value::Float(ratio as f64));
    if let Some(n) = p.take("nonlinear") {
        if cx.bool_of(n)? {
            return Err(cx.el_err(
                n,
                "nonlinear = true is not supported (the diffuse part is plain Lambert)",
            ));
        }
    }
    Ok(())
}

/// The raw transform of a shape's `to_world` (`None` without one): its matrix.
pub(super) fn shape_transform(
    cx: &Cx,
    t: Option<&El>,
) -> Result<Option<Sp<RawTransform>>, SceneError> {
    let Some(t) = t else { return Ok(None) };
    Ok(Some(matrix_transform(t, &to_world(cx, t)?.m)))
}

/// The composed `to_world` `m` of the element `t` as a shape's `transform.matrix`.
pub(super) fn matrix_transform(t: &El, m: &glam::DMat4) -> Sp<RawTransform> {
    let matrix = Arr(rows(m).map(Arr));
    sp(
        t,
        RawTransform {
            translate: None,
            scale: None,
            rotate_y_deg: None,
            rotate: None,
            matrix: Some(sp(t, matrix)),
        },
    )
}

/// A raw shape with nothing set but its name and material.
pub(super) fn raw_shape(el: &El, material: Sp<String>) -> RawShape {
    RawShape {
        name: el.attr("id").map(str::to_string),
        material,
        emission: None,
        quads: None,
        triangles: None,
        sphere: None,
        obj: None,
        ply: None,
        mtl: None,
        face_normals: None,
        transform: None,
        as_written: false,
        mitsuba_mesh: false,
        sides: crate::scene::schema::Sides::Winding,
        triangle_uvs: None,
        flip_mesh: false,
    }
}

pub(super) fn raw_sphere(el: &El, center: [f64; 3], radius: f64, inward: bool) -> Sp<RawSphere> {
    sp(
        el,
        RawSphere {
            center: sp(el, Arr(center)),
            radius: sp(el, radius),
            inward,
        },
    )
}
