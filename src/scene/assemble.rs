//! Assembly: the raw scene ([`super::schema`]) checked value by value and turned into the flat
//! primitive lists of [`Scene`] (quads, triangles, spheres, OBJ meshes, each transformed and
//! tagged with its material and emitter).

use super::error::SceneError;
use super::geometry::{degenerate, edge_overflow, Transform, TriangleSink};
use super::obj::{obj_triangles, ObjShape};
use super::schema::{
    Arr, MaterialTable, RawCamera, RawIntegrator, RawScene, RawShape, RawSphere, Triple, V3,
};
use super::spanned::{Cx, Sp};
use super::{Camera, Emitter, Integrator, Scene, Sphere, Triangle, VertexAttributes};
use crate::brdf::params::fmt_num;
use crate::brdf::{self, Origin};
use glam::{Vec2, Vec3};
use std::collections::{BTreeMap, HashMap};
use std::ops::Range;
use std::path::Path;

use crate::conventions::{MAX_DEPTH, MAX_FILM_SIZE};

/// A vector for a message, `[x, y, z]`, each number as [`fmt_num`] writes it.
pub(super) fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", fmt_num(v.x), fmt_num(v.y), fmt_num(v.z))
}

impl Cx<'_> {
    pub(super) fn finite(
        &self,
        span: Option<Range<usize>>,
        field: &str,
        x: f64,
    ) -> Result<f32, SceneError> {
        crate::numbers::f32_of(x).map_err(|msg| self.err(span, field, msg))
    }

    pub(super) fn vec3(
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

    pub(super) fn v3(&self, v: &V3, field: &str) -> Result<Vec3, SceneError> {
        self.vec3(v.span(), field, v.value.0)
    }

    /// A non-negative RGB radiance.
    pub(super) fn radiance(&self, v: &Sp<Triple>, field: &str) -> Result<Vec3, SceneError> {
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

    pub(super) fn at_least_one(
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

pub(super) fn build(cx: &mut Cx, raw: RawScene, path: &Path) -> Result<Scene, SceneError> {
    // The film first: a Mitsuba camera's field of view is computed from the film's aspect, so
    // a film of width 0 must be named as that, not as the field of view it made.
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
    let camera = camera(cx, &raw.camera)?;

    let integrator = integrator(cx, raw.integrator.as_ref())?;

    let (environment, environment_map) =
        super::environment::environment(cx, raw.environment.as_ref())?;
    // The depth limit of the renderers (`--max-depth` is held to the same): the random-number
    // key of a deeper segment would reuse another depth's numbers.
    if let Some(d) = raw.integrator.as_ref().and_then(|i| i.max_depth.as_ref()) {
        if d.value > MAX_DEPTH {
            let msg = format!("{} is out of range: must be in [1, {MAX_DEPTH}]", d.value);
            return Err(cx.err(d.span(), "integrator.max_depth", msg));
        }
    }

    let (mut materials, mut material_names, material_spans, mut material_params) =
        materials(cx, raw.materials)?;
    let index: HashMap<&str, usize> = material_names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect();
    let mut used = vec![false; materials.len()];

    let mut out = Shapes {
        material_base: materials.len() as u32,
        camera: camera.position,
        ..Shapes::default()
    };
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
        let textured = !materials[material].textures.is_empty();
        shape_primitives(cx, &f, shape, (material as u32, textured), &mut out)?;
    }

    // The MTL materials of OBJ shapes with `mtl = true` follow the scene's own.
    for (name, m, params) in std::mem::take(&mut out.mtl_materials) {
        material_names.push(name);
        materials.push(m);
        material_params.push(params);
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
        return Err(no_primitives(cx, &raw.shapes));
    }
    let lights = super::delta_lights::delta_lights(cx, &raw.lights)?;
    if out.emitters.is_empty()
        && lights.is_empty()
        && environment == Vec3::ZERO
        && environment_map.is_none()
    {
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
        material_params,
        emitters: out.emitters,
        triangles: out.triangles,
        attributes: out.attributes,
        spheres: out.spheres,
        lights,
        environment,
        environment_map,
        warnings: std::mem::take(&mut cx.warnings),
    })
}

/// The `[integrator]` table, each value checked; the defaults without it.
fn integrator(cx: &Cx, raw: Option<&RawIntegrator>) -> Result<Integrator, SceneError> {
    let mut integrator = Integrator::default();
    if let Some(i) = raw {
        let d = Integrator::default();
        integrator.spp = cx.at_least_one(&i.spp, "integrator.spp", d.spp)?;
        integrator.max_depth =
            cx.at_least_one(&i.max_depth, "integrator.max_depth", d.max_depth)?;
        integrator.seed = i.seed.unwrap_or(d.seed);
        integrator.russian_roulette = i.russian_roulette.unwrap_or(d.russian_roulette);
        integrator.hide_emitters = i.hide_emitters.unwrap_or(d.hide_emitters);
        integrator.rr_start_depth = cx.at_least_one(
            &i.rr_start_depth,
            "integrator.rr_start_depth",
            d.rr_start_depth,
        )?;
        if let Some(name) = &i.sampler {
            integrator.sampler = crate::rng::Sampler::parse(&name.value).ok_or_else(|| {
                let msg = format!(
                    "unknown sampler {:?}: expected one of {}",
                    name.value,
                    crate::rng::Sampler::names()
                );
                cx.err(name.span(), "integrator.sampler", &msg)
            })?;
        }
    }
    Ok(integrator)
}

/// The materials, in file order (the map is sorted by name; the spans give the order): each
/// parsed by its model, with its name and the span of its table.
/// Also each material's parameters as written (`Scene::material_params`).
#[allow(clippy::type_complexity)]
fn materials(
    cx: &mut Cx,
    raw: BTreeMap<String, Sp<MaterialTable>>,
) -> Result<
    (
        Vec<brdf::Material>,
        Vec<String>,
        Vec<Option<Range<usize>>>,
        Vec<BTreeMap<String, toml::Value>>,
    ),
    SceneError,
> {
    let mut defs: Vec<(String, Option<Range<usize>>, MaterialTable)> = Vec::new();
    for (name, table) in raw {
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
    let mut params = Vec::new();
    let mut cache = super::textures::TextureCache::default();
    for (name, span, mut table) in defs {
        // The fields as written, texture tables included (`Scene::material_params`).
        let written: BTreeMap<String, toml::Value> = table
            .iter()
            .filter(|(k, _)| *k != "twosided")
            .map(|(k, v)| (k.clone(), v.value.clone()))
            .collect();
        let textures = super::textures::texture_fields(cx, &name, &mut table, &mut cache)?;
        // The spans are made relative to the file that holds the table (one of several for
        // a Mitsuba scene with includes).
        let table_span = span.clone().unwrap_or(0..0);
        let (file, source, at) = cx.part_of(table_span.start);
        let mut fields = BTreeMap::new();
        let mut twosided = false;
        for (key, v) in table {
            if key == "twosided" {
                // A flag of the scene's surface, not a model parameter.
                match &v.value {
                    toml::Value::Boolean(b) => twosided = *b,
                    other => {
                        let msg = format!("expected true or false, found {other}");
                        return Err(cx.err(v.span(), &format!("materials.{name}.twosided"), msg));
                    }
                }
                continue;
            }
            let Some(s) = v.span() else {
                let msg = format!(
                    "material '{name}': a parameter cannot be a table (dotted key '{key}.…')"
                );
                return Err(cx.err(span, &format!("materials.{name}.{key}"), msg));
            };
            fields.insert(key, toml::Spanned::new(s.start - at..s.end - at, v.value));
        }
        params.push(written);
        let origin = Origin {
            file,
            source,
            material: &name,
            span: table_span.start - at..table_span.end - at,
            dir: Some(&cx.dir),
        };
        let (mut m, w) = brdf::parse_material(origin, fields)?;
        m.twosided = twosided;
        super::textures::bind(&mut m, textures);
        cx.warnings.extend(w);
        materials.push(m);
        material_names.push(name);
        material_spans.push(span);
    }
    Ok((materials, material_names, material_spans, params))
}

/// The error of a scene without primitives: none given, or shapes whose geometry came to
/// nothing.
fn no_primitives(cx: &Cx, shapes: &[Sp<RawShape>]) -> SceneError {
    // With shapes present, their geometry came to nothing (OBJ or PLY files without faces, with
    // lines only, or only zero-area triangles): the warnings say which and why.
    let msg = if shapes.is_empty() {
        "the scene has no primitives: add a [[shapes]] table with geometry".to_string()
    } else {
        let why: Vec<String> = cx
            .warnings
            .iter()
            .filter(|w| w.contains("OBJ") || w.contains("PLY"))
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
    match shapes.first() {
        Some(s) => cx.err(s.span().or(s.value.material.span()), "shapes", msg),
        None => cx.err(None, "shapes", msg),
    }
}

pub(super) fn camera(cx: &Cx, c: &RawCamera) -> Result<Camera, SceneError> {
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
    let (aperture_radius, focus_distance) = lens(cx, c, diff)?;
    Ok(Camera {
        position,
        target,
        up,
        fov_y_deg: fov,
        aperture_radius,
        focus_distance,
        mirror: c.mirror.as_ref().is_some_and(|m| m.value),
    })
}

/// The thin lens of `[camera]`: `aperture_radius` ≥ 0 (0, the default, is a pinhole) and
/// `focus_distance` > 0, by default the distance to the target (`diff` = target − position).
fn lens(cx: &Cx, c: &RawCamera, diff: Vec3) -> Result<(f32, f32), SceneError> {
    let aperture = match &c.aperture_radius {
        Some(a) => {
            let v = cx.finite(a.span(), "camera.aperture_radius", a.value)?;
            if v < 0.0 {
                let msg = format!(
                    "{} is out of range: the aperture radius must be >= 0 (0: a pinhole)",
                    fmt_num(v)
                );
                return Err(cx.err(a.span(), "camera.aperture_radius", msg));
            }
            v
        }
        None => 0.0,
    };
    let focus = match &c.focus_distance {
        Some(f) => {
            let v = cx.finite(f.span(), "camera.focus_distance", f.value)?;
            if v <= 0.0 {
                let msg = format!(
                    "{} is out of range: the focus distance must be > 0",
                    fmt_num(v)
                );
                return Err(cx.err(f.span(), "camera.focus_distance", msg));
            }
            if aperture == 0.0 && c.aperture_radius.is_none() {
                let msg = "focus_distance applies only to a thin lens: give aperture_radius too";
                return Err(cx.err(f.span(), "camera.focus_distance", msg));
            }
            v
        }
        None => (diff.as_dvec3().length() as f32).max(f32::MIN_POSITIVE),
    };
    Ok((aperture, focus))
}

#[derive(Default)]
pub(super) struct Shapes {
    pub(super) triangles: Vec<Triangle>,
    /// The triangles' vertex attributes (`Scene::attributes`).
    pub(super) attributes: Vec<VertexAttributes>,
    pub(super) spheres: Vec<Sphere>,
    pub(super) emitters: Vec<Emitter>,
    /// Materials read from MTL files (`mtl = true`), with their names.
    pub(super) mtl_materials: Vec<(String, brdf::Material, super::mtl::Params)>,
    /// The number of the scene's own materials (the MTL ones are numbered from it).
    pub(super) material_base: u32,
    /// The camera's position, which spheres are checked against
    /// ([`crate::robust::sphere_precision_problem`]).
    pub(super) camera: Vec3,
}

/// The primitives of one shape, of material `material`; `textured`: the material has textures,
/// so a quad gets its own texture coordinates (`crate::texture`).
pub(super) fn shape_primitives(
    cx: &mut Cx,
    f: &str,
    shape: &Sp<RawShape>,
    (material, textured): (u32, bool),
    out: &mut Shapes,
) -> Result<(), SceneError> {
    let s = &shape.value;
    let label = match &s.name {
        Some(n) => format!("shape '{n}'"),
        None => format!("shape {f}"),
    };

    one_geometry_kind(cx, f, shape, &label)?;
    let xf = match &s.transform {
        Some(t) => Some(super::transform::transform(cx, f, t, s.sides)?),
        None => None,
    };
    // A point of a quad or triangle, placed by the shape's transform and still finite.
    let place = |cx: &Cx, span: Option<Range<usize>>, field: &str, v: [f64; 3]| {
        let p = cx.vec3(span.clone(), field, v)?;
        let Some(xf) = &xf else { return Ok(p) };
        let q = xf.point(p);
        if !q.is_finite() {
            let msg = format!("the transform moves vertex {p} out of the single-precision range");
            return Err(cx.err(span, field, msg));
        }
        Ok(q)
    };
    let MeshOptions {
        use_mtl,
        face_normals,
    } = mesh_options(cx, f, shape)?;
    let first_mesh_triangle = out.triangles.len();
    let emitter = match &s.emission {
        Some(e) => shape_emitter(cx, f, e, out)?,
        None => None,
    };

    let tri = |v: [Vec3; 3]| Triangle {
        v,
        material,
        emitter,
    };
    if let Some(quads) = &s.quads {
        let tris = &mut out.triangles;
        let first = tris.len();
        polygon_triangles(cx, (f, &label, "quad"), quads, &place, &tri, tris)?;
        if textured {
            // Each quad's own (u, v): (0, 0), (1, 0), (1, 1), (0, 1) at v0 … v3.
            let (a, b, c, d) = (Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y);
            out.attributes.resize(first, VertexAttributes::NONE);
            for k in first..out.triangles.len() {
                let uv = if (k - first) % 2 == 0 {
                    [a, b, c]
                } else {
                    [a, c, d]
                };
                out.attributes.push(VertexAttributes {
                    n: None,
                    uv: Some(uv),
                });
            }
        }
    }
    if let Some(listed) = &s.triangles {
        let tris = &mut out.triangles;
        let first = tris.len();
        polygon_triangles(cx, (f, &label, "triangle"), listed, &place, &tri, tris)?;
        if let (true, Some(uvs)) = (textured, &s.triangle_uvs) {
            out.attributes.resize(first, VertexAttributes::NONE);
            out.attributes.extend(uvs.iter().map(|t| VertexAttributes {
                n: None,
                uv: Some(t.map(Vec2::from_array)),
            }));
        }
    }
    if let Some(sp) = &s.sphere {
        let placed = xf.as_ref().zip(s.transform.as_ref().map(|t| t.span()));
        let sphere = sphere_primitive(cx, f, &sp.value, placed, (material, emitter))?;
        if let Some(why) =
            crate::robust::sphere_precision_problem(sphere.center, sphere.radius, out.camera)
        {
            let msg = format!("{label}: {why}");
            return Err(cx.err(sp.value.radius.span(), &format!("{f}.sphere.radius"), msg));
        }
        out.spheres.push(sphere);
    }
    // A mesh's vertices: placed by the transform, or taken as written (a Mitsuba XML twin's
    // exact geometry), else as they are.
    let mesh_xf = match xf {
        Some(xf) => xf,
        None if s.as_written => Transform::AsWritten,
        None => Transform::identity(),
    };
    if let Some(ply) = &s.ply {
        let xf = &mesh_xf;
        let mesh = ObjShape {
            field: format!("{f}.ply"),
            label: label.clone(),
            material,
            emitter,
            sides: s.sides,
            flip: s.flip_mesh,
            smooth: s.mitsuba_mesh && !face_normals,
            mitsuba: s.mitsuba_mesh,
        };
        let sink = TriangleSink {
            triangles: &mut out.triangles,
            attributes: &mut out.attributes,
        };
        super::ply_shape::ply_triangles(cx, &mesh, ply, xf, sink)?;
    }
    if let Some(obj) = &s.obj {
        let xf = mesh_xf;
        let mesh = ObjShape {
            field: format!("{f}.obj"),
            label,
            material,
            emitter,
            sides: s.sides,
            flip: s.flip_mesh,
            smooth: s.mitsuba_mesh && !face_normals,
            mitsuba: s.mitsuba_mesh,
        };
        let mut mo = super::mtl::MtlOut {
            materials: &mut out.mtl_materials,
            emitters: &mut out.emitters,
            base: out.material_base,
        };
        let mtl = use_mtl.then_some(&mut mo);
        let sink = TriangleSink {
            triangles: &mut out.triangles,
            attributes: &mut out.attributes,
        };
        obj_triangles(cx, &mesh, obj, &xf, sink, mtl)?;
    }
    if face_normals {
        for a in out.attributes.iter_mut().skip(first_mesh_triangle) {
            a.n = None;
        }
    }
    Ok(())
}

/// The switches that apply to mesh shapes only.
struct MeshOptions {
    /// `mtl`: the OBJ file's own materials (obj only).
    use_mtl: bool,
    /// `face_normals`: drop the file's vertex normals (obj and ply).
    face_normals: bool,
}

/// The shape's mesh switches; one given on a shape of another kind is an error.
fn mesh_options(cx: &Cx, f: &str, shape: &Sp<RawShape>) -> Result<MeshOptions, SceneError> {
    let s = &shape.value;
    let use_mtl = match &s.mtl {
        Some(m) if s.obj.is_none() => {
            let msg = "mtl applies only to obj shapes";
            return Err(cx.err(m.span().or(shape.span()), &format!("{f}.mtl"), msg));
        }
        Some(m) => m.value,
        None => false,
    };
    let face_normals = match &s.face_normals {
        Some(n) if s.obj.is_none() && s.ply.is_none() => {
            let msg = "face_normals applies only to obj and ply shapes";
            return Err(cx.err(n.span().or(shape.span()), &format!("{f}.face_normals"), msg));
        }
        Some(n) => n.value,
        None => false,
    };
    Ok(MeshOptions {
        use_mtl,
        face_normals,
    })
}

/// The emitter of a shape's `emission` (its index in `out.emitters`), or `None` for zero
/// radiance: a shape that emits nothing is no light.
fn shape_emitter(
    cx: &Cx,
    f: &str,
    emission: &Sp<Triple>,
    out: &mut Shapes,
) -> Result<Option<u32>, SceneError> {
    let radiance = cx.radiance(emission, &format!("{f}.emission"))?;
    if radiance == Vec3::ZERO {
        return Ok(None);
    }
    out.emitters.push(Emitter { radiance });
    Ok(Some(out.emitters.len() as u32 - 1))
}

/// Refuses a shape with no geometry, or with more than one kind.
fn one_geometry_kind(
    cx: &Cx,
    f: &str,
    shape: &Sp<RawShape>,
    label: &str,
) -> Result<(), SceneError> {
    let s = &shape.value;
    let kinds: Vec<(&str, Option<Range<usize>>)> = [
        s.quads.as_ref().map(|q| ("quads", q.span())),
        s.triangles.as_ref().map(|q| ("triangles", q.span())),
        s.sphere
            .as_ref()
            .map(|q| ("sphere", q.span().or(q.value.radius.span()))),
        s.obj.as_ref().map(|q| ("obj", q.span())),
        s.ply.as_ref().map(|q| ("ply", q.span())),
    ]
    .into_iter()
    .flatten()
    .collect();
    match kinds.as_slice() {
        [] => {
            let msg = format!(
                "{label} has no geometry: give exactly one of quads, triangles, sphere, obj, ply"
            );
            Err(cx.err(shape.span().or(s.material.span()), f, msg))
        }
        [_] => Ok(()),
        [(a, _), (b, span), ..] => {
            let msg =
                format!("{label} has both {a} and {b}: give exactly one geometry kind per shape");
            Err(cx.err(span.clone(), &format!("{f}.{b}"), msg))
        }
    }
}

/// A point of a quad or triangle (its span and field name for messages), placed by the shape's
/// transform.
type Place<'a> = dyn Fn(&Cx, Option<Range<usize>>, &str, [f64; 3]) -> Result<Vec3, SceneError> + 'a;

/// The placed vertices of a listed polygon `q` (field `fq`).
fn placed<const N: usize>(
    cx: &Cx,
    fq: &str,
    q: &Sp<Arr<Arr<f64, 3>, N>>,
    place: &Place,
) -> Result<[Vec3; N], SceneError> {
    let mut p = [Vec3::ZERO; N];
    for (j, v) in q.value.iter().enumerate() {
        p[j] = place(cx, q.span(), fq, v.0)?;
    }
    Ok(p)
}

/// A shape's `quads` (`kind` "quad", two triangles each: v0 v1 v2, v0 v2 v3) or `triangles`
/// (`kind` "triangle"); an empty list, an edge out of range or a zero-area triangle is refused.
fn polygon_triangles<const N: usize>(
    cx: &Cx,
    (f, label, kind): (&str, &str, &str),
    list: &Sp<Vec<Sp<Arr<Arr<f64, 3>, N>>>>,
    place: &Place,
    tri: &dyn Fn([Vec3; 3]) -> Triangle,
    out: &mut Vec<Triangle>,
) -> Result<(), SceneError> {
    let field = format!("{f}.{kind}s");
    if list.value.is_empty() {
        let msg = format!("{label}: the list of {kind}s is empty");
        return Err(cx.err(list.span(), &field, msg));
    }
    for (k, q) in list.value.iter().enumerate() {
        let fq = format!("{field}[{k}]");
        let p: [Vec3; N] = placed(cx, &fq, q, place)?;
        for half in 0..N - 2 {
            let idx = [0, half + 1, half + 2];
            let t = idx.map(|i| p[i]);
            if let Some(msg) = edge_overflow(&t) {
                return Err(cx.err(q.span(), &fq, format!("{label}, {kind} {k}: {msg}")));
            }
            if degenerate(&t) {
                let which = match N {
                    3 => format!("{label}, {kind} {k} has"),
                    _ => format!(
                        "{label}, {kind} {k}: its {} triangle (v{}, v{}, v{}) has",
                        ["first", "second"][half],
                        idx[0],
                        idx[1],
                        idx[2]
                    ),
                };
                let msg = format!("{which} zero area (collinear or repeated vertices)");
                return Err(cx.err(q.span(), &fq, msg));
            }
            out.push(tri(t));
        }
    }
    Ok(())
}

/// A shape's `sphere`, placed by the shape's transform (and its span) when it has one.
fn sphere_primitive(
    cx: &Cx,
    f: &str,
    r: &RawSphere,
    placed: Option<(&Transform, Option<Range<usize>>)>,
    (material, emitter): (u32, Option<u32>),
) -> Result<Sphere, SceneError> {
    let mut center = cx.v3(&r.center, &format!("{f}.sphere.center"))?;
    let fr = format!("{f}.sphere.radius");
    let mut radius = cx.finite(r.radius.span(), &fr, r.radius.value)?;
    if radius <= 0.0 {
        let msg = format!(
            "{} is out of range: the radius must be > 0",
            fmt_num(radius)
        );
        return Err(cx.err(r.radius.span(), &fr, msg));
    }
    let mut frame = None;
    if let Some((xf, span)) = placed {
        (center, radius) = transformed_sphere(cx, f, span, xf, center, radius)?;
        frame = sphere_frame(xf);
    }
    Ok(Sphere {
        center,
        radius,
        material,
        emitter,
        inward: r.inward,
        frame,
    })
}

/// The frame a similarity `xf` turns a sphere by, as the inverse of its rotation (`W = Rᵀ`,
/// with `R` the linear part over its scale), or `None` when it turns nothing.
fn sphere_frame(xf: &Transform) -> Option<crate::scene::SphereFrame> {
    let s = xf.similarity_scale()?;
    let (a, _) = xf.affine();
    let mut w = (a * (1.0 / s)).transpose();
    let mirror = w.determinant() < 0.0;
    if mirror {
        // W = D·Q with D = diag(1, 1, −1): Q = D·W, W's last row negated.
        w = glam::DMat3::from_cols(
            w.x_axis * glam::DVec3::new(1.0, 1.0, -1.0),
            w.y_axis * glam::DVec3::new(1.0, 1.0, -1.0),
            w.z_axis * glam::DVec3::new(1.0, 1.0, -1.0),
        );
    }
    let off = (w - glam::DMat3::IDENTITY).to_cols_array();
    if !mirror && off.iter().all(|x| x.abs() <= 1e-12) {
        return None;
    }
    let q = glam::DQuat::from_mat3(&w).normalize();
    Some(crate::scene::SphereFrame {
        q: [q.x as f32, q.y as f32, q.z as f32, q.w as f32],
        mirror,
    })
}

/// A sphere under a transform: only a similarity keeps it a sphere.
fn transformed_sphere(
    cx: &Cx,
    f: &str,
    span: Option<Range<usize>>,
    xf: &Transform,
    center: Vec3,
    radius: f32,
) -> Result<(Vec3, f32), SceneError> {
    let Some(s) = xf.similarity_scale() else {
        let msg = "a sphere's transform must be a similarity (rotation, uniform scale, translation): any other map makes an ellipsoid";
        return Err(cx.err(span, &format!("{f}.transform"), msg));
    };
    let (c, r) = (xf.point(center), (radius as f64 * s) as f32);
    if !(c.is_finite() && r.is_finite() && r > 0.0) {
        let msg = "the transform moves the sphere out of the single-precision range";
        return Err(cx.err(span, &format!("{f}.transform"), msg));
    }
    Ok((c, r))
}
