//! The OBJ reader: a line-by-line check of the file (tobj reports no line numbers), then
//! tobj's triangulated meshes turned into [`Triangle`]s with the shape's transform, material
//! and emitter.

use super::error::SceneError;
use super::geometry::{
    edge_overflow, mesh_path, vertex_normals, FaceRules, Transform, TriangleSink,
};
use super::mtl::{mtl_material, scan_mtl, MtlLibrary, MtlOut};
use super::spanned::{Cx, Sp};
use super::{Triangle, VertexAttributes};
use glam::{Vec2, Vec3};
use std::ops::Range;
use std::path::Path;

/// What [`scan_obj`] found besides the geometry: the MTL libraries and materials the file names,
/// with their lines.
#[derive(Debug, Default, PartialEq)]
pub(super) struct ObjScan {
    /// `mtllib NAME` lines: (line, NAME as tobj reads it: the rest of the line, trimmed).
    pub(super) mtllibs: Vec<(usize, String)>,
    /// `usemtl NAME` lines.
    pub(super) usemtls: Vec<(usize, String)>,
    /// Whether the file has vertex normals (`vn`).
    pub(super) normals: bool,
}

impl ObjScan {
    /// Whether the file refers to MTL materials.
    pub(super) fn uses_mtl(&self) -> bool {
        !self.mtllibs.is_empty() || !self.usemtls.is_empty()
    }
}

/// Checks the face indices of an OBJ text line by line (tobj reports no line numbers, and
/// some malformed relative indices make its index arithmetic overflow), and the numbers (one
/// beyond single precision is refused as written, [`crate::numbers`]). Returns the MTL
/// libraries and materials the file names.
pub(super) fn scan_obj(text: &str) -> Result<ObjScan, (usize, String)> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    let mut found = ObjScan::default();
    for (l, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let kw = words.next();
        // tobj reports malformed numbers without a line ("position parse error"): check them.
        if let Some((what, min, max)) = match kw {
            // x y z, then w (a weight, ignored) or r g b (a colour, not used).
            Some("v") => Some(("vertex position", 3, 6)),
            Some("vt") => Some(("texture coordinate", 1, 3)),
            Some("vn") => Some(("normal", 3, 3)),
            _ => None,
        } {
            let nums: Vec<&str> = line.split_whitespace().skip(1).collect();
            if nums.len() < min || nums.len() > max || (kw == Some("v") && nums.len() == 5) {
                let want = match kw {
                    Some("v") => "3 (x y z), 4 (x y z w) or 6 (x y z r g b)".to_string(),
                    _ if min == max => format!("{min}"),
                    _ => format!("{min} to {max}"),
                };
                return Err((
                    l + 1,
                    format!("a {what} needs {want} numbers, found {}", nums.len()),
                ));
            }
            if let Some(bad) = nums.iter().find(|x| x.parse::<f32>().is_err()) {
                let bad = crate::errors::excerpt(bad);
                return Err((l + 1, format!("{what}: '{bad}' is not a number")));
            }
            // Finite as written but not in single precision: named as written, not as inf.
            for x in &nums {
                if x.parse::<f32>().is_ok_and(f32::is_infinite) {
                    if let Err(msg) = crate::numbers::parse_f32(x) {
                        return Err((l + 1, format!("{what}: {msg}")));
                    }
                }
            }
        }
        match kw {
            Some("v") => nv += 1,
            Some("vt") => nt += 1,
            Some("vn") => {
                nn += 1;
                found.normals = true;
            }
            Some(kw @ ("mtllib" | "usemtl")) => {
                let entry = (l + 1, rest_of(line).to_string());
                match kw {
                    "mtllib" => found.mtllibs.push(entry),
                    _ => found.usemtls.push(entry),
                }
            }
            Some(kw @ ("f" | "l")) => {
                let mut count = 0;
                for word in words {
                    count += 1;
                    let w = crate::errors::excerpt(word);
                    let parts: Vec<&str> = word.split('/').collect();
                    if parts.len() > 3 {
                        return Err((l + 1, format!("'{w}' has more than three indices")));
                    }
                    let kinds = [("vertex", nv), ("texture coordinate", nt), ("normal", nn)];
                    for (p, (kind, n)) in parts.iter().zip(kinds) {
                        if p.is_empty() && kind != "vertex" {
                            continue;
                        }
                        let i: i64 = p.parse().map_err(|_| {
                            let p = crate::errors::excerpt(p);
                            (l + 1, format!("'{w}': '{p}' is not an index"))
                        })?;
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
    Ok(found)
}

/// What an OBJ shape's triangles get, and how its messages name it.
pub(super) struct ObjShape {
    pub(super) field: String,
    pub(super) label: String,
    pub(super) material: u32,
    pub(super) emitter: Option<u32>,
    /// Which side of a triangle is the front ([`FaceRules::new`]).
    pub(super) sides: super::schema::Sides,
    /// Every triangle turned over, winding and normals (Mitsuba's `flip_normals`).
    pub(super) flip: bool,
    /// A mesh without vertex normals gets smooth ones ([`super::geometry::vertex_normals`]),
    /// as Mitsuba gives them (set by the Mitsuba reader, unless `face_normals`).
    pub(super) smooth: bool,
    /// Read from a Mitsuba scene, where MTL materials are never read (as Mitsuba ignores them).
    pub(super) mitsuba: bool,
}

/// Where an OBJ file's messages point: the scene's span and field, and the file as shown.
struct At<'a> {
    span: Option<Range<usize>>,
    field: &'a str,
    shown: &'a str,
}

impl At<'_> {
    fn err(&self, cx: &Cx, msg: String) -> SceneError {
        cx.err(self.span.clone(), self.field, msg)
    }
    fn warn(&self, cx: &mut Cx, msg: String) {
        cx.warn(self.span.clone(), self.field, msg)
    }
}

/// The triangles of an OBJ shape, with the MTL materials of the faces when `mtl` is given (the
/// shape's `mtl = true`: [`super::mtl`]); faces without one get the shape's material and
/// emitter.
pub(super) fn obj_triangles(
    cx: &mut Cx,
    shape: &ObjShape,
    obj: &Sp<String>,
    xf: &Transform,
    mut out: TriangleSink,
    mut mtl: Option<&mut MtlOut>,
) -> Result<(), SceneError> {
    let full = mesh_path(cx, &obj.value);
    let shown = crate::errors::shown_path(&full);
    let at = At {
        span: obj.span(),
        field: shape.field.as_str(),
        shown: &shown,
    };
    let text = cx
        .read_referenced_text(&full, crate::infile::OBJ)
        .map_err(|e| at.err(cx, format!("cannot read OBJ file '{shown}': {e}")))?;
    // A plain file (positions and faces only) is read in parallel, else line-checked, then
    // read by tobj.
    let plain = super::obj_plain::read_plain(&text);
    let scan = match plain {
        Some(_) => ObjScan::default(),
        None => scan_obj(&text)
            .map_err(|(line, msg)| at.err(cx, format!("OBJ file '{shown}', line {line}: {msg}")))?,
    };
    // Smooth normals for the file's vertices: the file read as one model (`for_tobj`).
    let one_model = shape.smooth && !scan.normals;
    let uses_mtl = scan.uses_mtl();
    if uses_mtl && mtl.is_none() {
        let hint = match shape.mitsuba {
            true => "its BSDF, as in Mitsuba 3",
            false => "this shape's material (mtl = true uses them)",
        };
        at.warn(cx, format!("OBJ file '{shown}' refers to MTL materials; they are ignored: every face uses {hint}"));
    }
    if !uses_mtl && mtl.is_some() {
        at.warn(cx, format!("OBJ file '{shown}' has no MTL materials (mtllib, usemtl): every face uses this shape's material"));
    }
    let read_mtl = mtl.is_some() && uses_mtl;
    let libraries = match read_mtl {
        true => mtl_libraries(cx, &at, &full, &scan)?,
        false => Vec::new(),
    };
    let (models, library) = match plain {
        Some(model) => (vec![model], Vec::new()),
        None => parse_obj(cx, &at, &text, (read_mtl, one_model), &libraries)?,
    };
    drop(text);
    // Scene materials and emitters of the library's materials, made when a face uses them.
    let mut made: Vec<Option<(u32, Option<u32>)>> = vec![None; library.len()];
    let mut rules = FaceRules::new(shape.sides, shape.flip);
    for model in &models {
        let m = &model.mesh;
        let (material, emitter) = match (m.material_id, mtl.as_deref_mut()) {
            (Some(id), Some(mo)) if id < library.len() => match made[id] {
                Some(me) => me,
                None => {
                    let m = &library[id];
                    let lib = libraries
                        .iter()
                        .rev()
                        .map(|(_, l)| l)
                        .find(|l| l.lines_of(&m.name).is_some());
                    let Some(lib) = lib else {
                        let msg =
                            format!("OBJ file '{shown}': material '{}' of no library", m.name);
                        return Err(at.err(cx, msg));
                    };
                    let me = mtl_material(cx, at.span.clone(), at.field, &obj.value, (m, lib), mo)?;
                    made[id] = Some(me);
                    me
                }
            },
            _ => (shape.material, shape.emitter),
        };
        let nverts = m.positions.len() / 3;
        let has_n = !m.normals.is_empty() && m.normals.len() == 3 * nverts;
        let has_uv = !m.texcoords.is_empty() && m.texcoords.len() == 2 * nverts;
        for (attribute, given, usable) in [
            ("normals", !m.normals.is_empty(), has_n),
            ("texture coordinates", !m.texcoords.is_empty(), has_uv),
        ] {
            if given && !usable {
                let msg = format!(
                    "OBJ file '{shown}', object '{}': only some vertices have {attribute}; all are ignored",
                    model.name
                );
                at.warn(cx, msg);
            }
        }
        // Smooth normals where the model has none: computed from the placed vertices.
        let computed = (shape.smooth && !has_n).then(|| {
            let placed: Vec<Vec3> = m
                .positions
                .chunks_exact(3)
                .map(|p| xf.point(Vec3::from_slice(p)))
                .collect();
            vertex_normals(&placed, &m.indices)
        });
        rules.computed_normals(computed.is_some());
        let me = (material, emitter);
        model_triangles(
            cx,
            &at,
            model,
            xf,
            (has_n, has_uv, computed.as_deref()),
            me,
            &mut out,
            &mut rules,
        )?;
    }
    rules.warn(cx, at.span.clone(), at.field, ("OBJ", &shown, &shape.label));
    Ok(())
}

/// Faces per piece when a model's faces are placed and checked in parallel.
const FACES_PER_PIECE: usize = 1 << 15;

/// Appends the triangles of a tobj model to `out`: the faces placed and checked by
/// [`obj_face`] and [`FaceRules::face`] in parallel pieces, kept in order; the first error in
/// face order is the one reported, as in a serial pass. The pieces write straight into `out`
/// (its new memory is first touched on all threads: a copy of a million triangles into fresh
/// pages cost more than placing them), then the gaps of skipped faces close. The attributes
/// are written beside the triangles only when the model has normals (its own, or `computed`
/// ones in world space, per vertex) or texture coordinates (`attributes`).
#[allow(clippy::too_many_arguments)]
fn model_triangles(
    cx: &Cx,
    at: &At,
    model: &tobj::Model,
    xf: &Transform,
    attributes: (bool, bool, Option<&[Vec3]>),
    (material, emitter): (u32, Option<u32>),
    out: &mut TriangleSink,
    rules: &mut FaceRules,
) -> Result<(), SceneError> {
    use rayon::prelude::*;
    let indices = &model.mesh.indices;
    let faces = indices.len() / 3;
    let old = out.triangles.len();
    let unset = Triangle {
        v: [Vec3::ZERO; 3],
        material,
        emitter,
    };
    out.triangles
        .par_extend(rayon::iter::repeat_n(unset, faces));
    let with_attributes = attributes.0 || attributes.1 || attributes.2.is_some();
    if with_attributes {
        out.attributes.resize(old + faces, VertexAttributes::NONE);
    }
    // Each piece's attribute slots: its part of `out.attributes`, or none.
    let pieces = faces.div_ceil(FACES_PER_PIECE);
    let attribute_slots: Vec<&mut [VertexAttributes]> = match with_attributes {
        true => out.attributes[old..].chunks_mut(FACES_PER_PIECE).collect(),
        false => (0..pieces)
            .map(|_| <&mut [VertexAttributes]>::default())
            .collect(),
    };
    let part_rules = rules.part();
    let piece =
        |k: usize, dst: &mut [Triangle], dst_attributes: &mut [VertexAttributes], faces: &[u32]| {
            let mut rules = part_rules.part();
            let mut made = 0;
            for (t, face) in faces.chunks_exact(3).enumerate() {
                let face = (k * FACES_PER_PIECE + t, face);
                let (v, n, uv) = obj_face(cx, at, model, face, xf, attributes)?;
                if let Some((tri, a)) = rules.face(v, n, uv, material, emitter) {
                    dst[made] = tri;
                    if with_attributes {
                        dst_attributes[made] = a;
                    }
                    made += 1;
                }
            }
            Ok((made, rules))
        };
    let pieces: Vec<Result<(usize, FaceRules), SceneError>> = out.triangles[old..]
        .par_chunks_mut(FACES_PER_PIECE)
        .zip(attribute_slots)
        .zip(indices.par_chunks(3 * FACES_PER_PIECE))
        .enumerate()
        .map(|(k, ((dst, dst_attributes), faces))| piece(k, dst, dst_attributes, faces))
        .collect();
    let mut end = old;
    for (k, p) in pieces.into_iter().enumerate() {
        let (made, r) = p.inspect_err(|_| {
            out.triangles.truncate(old);
            out.attributes.truncate(old);
        })?;
        let first = old + k * FACES_PER_PIECE;
        for i in 0..made {
            out.triangles.swap(end + i, first + i);
            if with_attributes {
                out.attributes.swap(end + i, first + i);
            }
        }
        end += made;
        rules.add(&r);
    }
    out.triangles.truncate(end);
    if with_attributes {
        out.attributes.truncate(end);
    }
    Ok(())
}

/// The rest of a statement after its keyword, trimmed (a name that may hold spaces:
/// `usemtl`, `mtllib`).
fn rest_of(line: &str) -> &str {
    line.trim()
        .split_once(char::is_whitespace)
        .unwrap_or_default()
        .1
        .trim()
}

/// What [`for_tobj`] left out of the text or changed, for the warnings.
#[derive(Debug, Default, PartialEq)]
struct Rewritten {
    points: usize,
    polylines: usize,
    /// Vertex weights w (`v x y z w`) other than 1: how many, and the first one's line and w.
    weights: usize,
    first_weight: Option<(usize, String)>,
}

/// The text as tobj should read it, one statement a line in one form, so that what tobj makes
/// of a file is what OBJ readers and Mitsuba 3 make of it:
/// * `v x y z w` is `v x y z`: w weights the control points of rational curves and surfaces,
///   not polygon vertices, and Mitsuba and Blender read x y z as written (tobj divides by w,
///   and refuses w = 0); a vertex colour (`v x y z r g b`), never used, is dropped too (tobj
///   refuses a file where only some vertices have one);
/// * `vt u` is `vt u 0` (v defaults to 0);
/// * `usemtl` and `mtllib` are read with any whitespace after the keyword, and the libraries
///   before every face (tobj knows a material only after its `mtllib` line, and reads the name
///   after the first space only); without `read_mtl` (the scene assigns the material) both
///   are left out;
/// * points (`p`) and polylines (`l`) are left out (not surfaces: tobj's ignore_points /
///   ignore_lines drop only those of one and two vertices, and `l 1 2 3` became a face), as
///   are comments and statements tobj does not read;
/// * with `one_model`, `o` and `g` are left out too, so that tobj gives one model, whose
///   vertices are the file's vertices, (v, vt, vn) triples of indices, wherever they are used
///   (as Mitsuba 3 keys them; tobj keys them per model).
///
/// Lines left out stay as empty lines, after the libraries' lines. The input is the text
/// [`scan_obj`] checked.
fn for_tobj(text: &str, read_mtl: bool, one_model: bool) -> (String, Rewritten) {
    let mut changed = Rewritten::default();
    let mut libraries = String::new();
    let mut out = String::with_capacity(text.len() + 1);
    for (l, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let kw = words.next();
        match kw {
            // (tobj splits these at any whitespace: a line with nothing to drop goes as it is.)
            Some("v") if line.split_whitespace().nth(5).is_none() => {
                let (x, y, z) = (words.next(), words.next(), words.next());
                match words.next() {
                    None => out.push_str(line),
                    Some(w) => {
                        let xyz = [x, y, z].map(Option::unwrap_or_default);
                        out.push_str(&format!("v {} {} {}", xyz[0], xyz[1], xyz[2]));
                        if w.parse::<f32>().ok() != Some(1.0) {
                            changed.weights += 1;
                            changed.first_weight.get_or_insert((l + 1, w.to_string()));
                        }
                    }
                }
            }
            Some("v") => {
                // x y z r g b: the colour is not used.
                let xyz: Vec<&str> = words.take(3).collect();
                out.push_str(&format!("v {}", xyz.join(" ")));
            }
            Some("vt") if line.split_whitespace().nth(2).is_some() => out.push_str(line),
            Some("vt") => {
                out.push_str("vt ");
                out.push_str(words.next().unwrap_or("0"));
                out.push_str(" 0");
            }
            Some("vn" | "f") => out.push_str(line),
            Some("o" | "g") if !one_model => out.push_str(line.trim()),
            Some("usemtl") if read_mtl => {
                out.push_str("usemtl ");
                out.push_str(rest_of(line));
            }
            Some("mtllib") if read_mtl => {
                libraries.push_str("mtllib ");
                libraries.push_str(rest_of(line));
                libraries.push('\n');
            }
            Some("p") => changed.points += 1,
            Some("l") => changed.polylines += 1,
            _ => {}
        }
        out.push('\n');
    }
    (libraries + &out, changed)
}

/// The MTL libraries the OBJ file `full` names (`mtllib`, relative to the OBJ file), each read
/// bounded and checked line by line ([`scan_mtl`]), errors naming the OBJ line, the MTL file and
/// its line; with warnings for a library's unknown statements and for each `usemtl` of a
/// material no library defines (its faces get the shape's material).
fn mtl_libraries(
    cx: &mut Cx,
    at: &At,
    full: &Path,
    scan: &ObjScan,
) -> Result<Vec<(String, MtlLibrary)>, SceneError> {
    let shown = at.shown;
    let obj_dir = full.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut libraries: Vec<(String, MtlLibrary)> = Vec::new();
    for (line, name) in &scan.mtllibs {
        if libraries.iter().any(|(n, _)| n == name) {
            continue;
        }
        let path = obj_dir.join(name);
        let file = crate::errors::shown_path(&path);
        let text = cx
            .read_referenced_text(&path, crate::infile::MTL)
            .map_err(|e| {
                let msg = format!(
                    "OBJ file '{shown}', line {line}: cannot read the MTL library '{file}' \
                     (mtllib, relative to the OBJ file): {e}"
                );
                at.err(cx, msg)
            })?;
        let mut lib = scan_mtl(&text).map_err(|(l, msg)| {
            let msg = format!("MTL file '{file}' (mtllib of OBJ file '{shown}'), line {l}: {msg}");
            at.err(cx, msg)
        })?;
        if let Some((l, kw)) = lib.unknown.first() {
            let more = match lib.unknown.len() {
                1 => String::new(),
                n => format!(" and {} more", n - 1),
            };
            let msg =
                format!("MTL file '{file}', line {l}: unknown statement '{kw}'{more}, ignored");
            at.warn(cx, msg);
        }
        lib.file = file;
        lib.text = text;
        libraries.push((name.clone(), lib));
    }
    for (line, name) in &scan.usemtls {
        if name.is_empty() {
            let msg = format!("OBJ file '{shown}', line {line}: usemtl needs a material name");
            return Err(at.err(cx, msg));
        }
        if !libraries.iter().any(|(_, l)| l.lines_of(name).is_some()) {
            let known = match libraries.len() {
                0 => "the file names no MTL library (mtllib)".to_string(),
                _ => {
                    let files: Vec<&str> = libraries.iter().map(|(_, l)| l.file.as_str()).collect();
                    format!("no library defines it ({})", files.join(", "))
                }
            };
            let msg = format!(
                "OBJ file '{shown}', line {line}: usemtl '{}': {known}; its faces get the \
                 shape's material",
                crate::errors::excerpt(name)
            );
            at.warn(cx, msg);
        }
    }
    Ok(libraries)
}

/// tobj's triangulated models of the OBJ text ([`for_tobj`] rewrites it first; one model with
/// `one_model`), and its MTL library when `read_mtl` (the `libraries` read by
/// [`mtl_libraries`]; without `read_mtl` the file's libraries are not read: the scene file
/// assigns the material).
fn parse_obj(
    cx: &mut Cx,
    at: &At,
    text: &str,
    (read_mtl, one_model): (bool, bool),
    libraries: &[(String, MtlLibrary)],
) -> Result<(Vec<tobj::Model>, Vec<tobj::Material>), SceneError> {
    let shown = at.shown;
    let (text, changed) = for_tobj(text, read_mtl, one_model);
    let (points, polylines) = (changed.points, changed.polylines);
    if points + polylines > 0 {
        at.warn(cx, format!(
            "OBJ file '{shown}': {points} point and {polylines} line element(s) ('p', 'l') ignored: only faces ('f') are surfaces"
        ));
    }
    if let Some((line, w)) = &changed.first_weight {
        let more = match changed.weights {
            1 => String::new(),
            n => format!(" (and on {} more lines)", n - 1),
        };
        at.warn(cx, format!(
            "OBJ file '{shown}', line {line}: the vertex weight w = {}{more} is ignored: a vertex is x y z as written, as Mitsuba 3 and Blender read it (w weights rational curves and surfaces)",
            crate::errors::excerpt(w)
        ));
    }
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let loaded = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut text.as_bytes(), &opts, |p| {
            let lib = libraries
                .iter()
                .find(|(name, _)| read_mtl && Path::new(name) == p);
            match lib {
                Some((_, lib)) => tobj::load_mtl_buf(&mut lib.text.as_bytes()),
                None => Err(tobj::LoadError::OpenFileFailed),
            }
        })
    });
    let (models, libraries_read) = match loaded {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(at.err(cx, format!("cannot parse OBJ file '{shown}': {e}"))),
        Err(_) => {
            let msg = format!("cannot parse OBJ file '{shown}': malformed content");
            return Err(at.err(cx, msg));
        }
    };
    if !read_mtl {
        return Ok((models, Vec::new()));
    }
    // Every library was read and checked before; tobj reads them again from their text.
    let library = libraries_read
        .map_err(|e| at.err(cx, format!("OBJ file '{shown}': its MTL libraries: {e}")))?;
    Ok((models, library))
}

/// The placed vertices of face `t` of a tobj model (refused when not finite, or when an edge
/// overflows), with their normals and texture coordinates when the model has them.
#[allow(clippy::type_complexity)]
fn obj_face(
    cx: &Cx,
    at: &At,
    model: &tobj::Model,
    (t, face): (usize, &[u32]),
    xf: &Transform,
    (has_n, has_uv, computed): (bool, bool, Option<&[Vec3]>),
) -> Result<([Vec3; 3], Option<[Vec3; 3]>, Option<[Vec2; 3]>), SceneError> {
    let (m, shown, name) = (&model.mesh, at.shown, &model.name);
    let mut v = [Vec3::ZERO; 3];
    let mut n = [Vec3::ZERO; 3];
    let mut uv = [Vec2::ZERO; 3];
    for j in 0..3 {
        let i = face[j] as usize;
        let Some(p) = m.positions.get(3 * i..3 * i + 3) else {
            return Err(at.err(cx, format!("OBJ file '{shown}': vertex index out of range")));
        };
        let p = Vec3::new(p[0], p[1], p[2]);
        if !p.is_finite() {
            let msg = format!(
                "OBJ file '{shown}', object '{name}', triangle {t}: vertex {p} is not finite"
            );
            return Err(at.err(cx, msg));
        }
        v[j] = xf.point(p);
        if !v[j].is_finite() {
            let msg = format!(
                "OBJ file '{shown}': the transform moves vertex {p} out of the single-precision range"
            );
            return Err(at.err(cx, msg));
        }
        if let Some(c) = computed {
            n[j] = c[i];
        } else if has_n {
            n[j] = xf.normal(Vec3::from_slice(&m.normals[3 * i..3 * i + 3]));
        }
        if has_uv {
            // OBJ's v runs up the image; a texture's v down from its top row (as Mitsuba 3
            // reads OBJ files: `crate::texture`).
            uv[j] = Vec2::new(m.texcoords[2 * i], 1.0 - m.texcoords[2 * i + 1]);
        }
    }
    if let Some(msg) = edge_overflow(&v) {
        let msg = format!("OBJ file '{shown}', object '{name}', triangle {t}: {msg}");
        return Err(at.err(cx, msg));
    }
    let has_n = has_n || computed.is_some();
    Ok((v, has_n.then_some(n), has_uv.then_some(uv)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The text tobj reads: one form a statement, w and colours dropped, `vt u` padded, the
    /// libraries first, and what tobj should not see left out (lines kept empty).
    #[test]
    fn for_tobj_writes_one_form() {
        let text = "# c\nv 1 2 3 2\r\n  v 4 5 6 0.1 0.2 0.3\nvt 0.5\n\tusemtl   red \ng part\nf 1 2 3\nmtllib\ta b.mtl\np 1\nl 1 2\n";
        let (out, changed) = for_tobj(text, true, false);
        assert_eq!(
            out,
            "mtllib a b.mtl\n\nv 1 2 3\nv 4 5 6\nvt 0.5 0\nusemtl red\ng part\nf 1 2 3\n\n\n\n"
        );
        assert_eq!(
            (changed.points, changed.polylines, changed.weights),
            (1, 1, 1)
        );
        assert_eq!(changed.first_weight, Some((2, "2".to_string())));
        // Without MTL materials their statements go; one model: no groups.
        let (out, _) = for_tobj(text, false, true);
        assert_eq!(out, "\nv 1 2 3\nv 4 5 6\nvt 0.5 0\n\n\nf 1 2 3\n\n\n\n");
    }

    #[test]
    fn obj_scan_checks_indices() {
        assert_eq!(
            scan_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf -3 -2 -1\n"),
            Ok(ObjScan::default())
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
        let found = scan_obj("mtllib a b.mtl\nv 0 0 0\nusemtl  red \n").unwrap();
        assert_eq!(found.mtllibs, vec![(1, "a b.mtl".to_string())]);
        assert_eq!(found.usemtls, vec![(3, "red".to_string())]);
        assert!(found.uses_mtl());
        // A number beyond single precision is named as written, with its line.
        let (line, msg) = scan_obj("v 0 0 0\nv 1e39 0 0\n").unwrap_err();
        assert_eq!(line, 2);
        assert!(
            msg.contains("'1e39'") && msg.contains("single-precision"),
            "{msg}"
        );
    }
}
