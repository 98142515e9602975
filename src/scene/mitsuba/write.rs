//! The Mitsuba 3 XML writer behind `brdfwave convert SCENE --to mitsuba OUT.xml`: a loaded
//! [`Scene`] as an XML file and the OBJ meshes beside it.
//!
//! **Exact geometry.** The triangles are written as they are after loading (world space, in
//! their order), each run of triangles with the same material and emitter one OBJ file, every
//! number with `{}` of its f32 (the shortest text that reads back to the same f32); the reader
//! takes an OBJ without `to_world` as written, so the XML file loads to the very same
//! triangles, normals and texture coordinates. Spheres, the camera (a `lookat` with
//! `fov_axis = "y"`), colours and parameters are written the same way, shapes in an order
//! that keeps the emitters' numbering. So a scene and its conversion render bit-identical
//! images (tests/mitsuba_xml.rs).
//!
//! **Materials.** Lambert is `diffuse`; Cook–Torrance with Walter et al.'s normalisation and
//! Smith shadowing is `roughconductor` (conductor Fresnel, or Schlick with f0 = 1 as
//! `material="none"`, kd = 0) or `roughplastic` (dielectric Fresnel), `conductor`/`plastic`
//! when it is a mirror. Every other material has no Mitsuba twin and is refused, unless
//! `brdfwave_plugins` is set: it is then written under brdfwave's own plugin name
//! (`<bsdf type="ward">`) with its parameters as the scene gave them, which only brdfwave reads.

use crate::brdf::cook_torrance::{CookTorrance, Distribution, Fresnel, Geometry, Normalization};
use crate::brdf::lambert::Lambert;
use crate::scene::{DeltaLight, Scene, Sphere, Triangle, VertexAttributes};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How to write what Mitsuba lacks.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Write the models Mitsuba lacks under brdfwave's own plugin names instead of refusing.
    pub brdfwave_plugins: bool,
    /// The directory the XML file goes to: a model's file parameter (a measured table) is
    /// written relative to it when the file lies below it, else as an absolute path. `None`:
    /// the scene file's directory.
    pub xml_dir: Option<std::path::PathBuf>,
}

/// The converted scene: the XML text and the OBJ files it refers to, `(name, text)` with names
/// relative to the XML file's directory.
pub struct Converted {
    pub xml: String,
    pub meshes: Vec<(String, String)>,
}

/// `s` as Mitsuba 3 XML; `mesh_dir` is the directory (relative to the XML file) the OBJ files
/// go to. The error says which material Mitsuba cannot express.
pub fn to_mitsuba(s: &Scene, mesh_dir: &str, opts: Options) -> Result<Converted, String> {
    let scene_dir = s.path.parent().unwrap_or(Path::new("."));
    let mut x = String::new();
    let _ = writeln!(x, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        x,
        "<!-- Written by `brdfwave convert` from {}. -->",
        attr(&s.path.file_name().unwrap_or_default().to_string_lossy()).replace("--", "- -")
    );
    x.push_str("<scene version=\"3.0.0\">\n");
    integrator(&mut x, s);
    sensor(&mut x, s);
    let ids = bsdf_ids(&s.material_names);
    for (i, m) in s.materials.iter().enumerate() {
        let name = (s.material_names[i].as_str(), ids[i].as_str());
        let b = bsdf(m, name, s.material_params.get(i), &opts, scene_dir)?;
        x.push_str(&if m.twosided { twosided(&b, name.1) } else { b });
    }
    if s.environment != Vec3::ZERO {
        let _ = writeln!(
            x,
            "    <emitter type=\"constant\">\n        <rgb name=\"radiance\" value=\"{}\"/>\n    </emitter>",
            rgb(s.environment)
        );
    }
    if let Some(m) = &s.environment_map {
        let dir = opts.xml_dir.as_deref().unwrap_or(scene_dir);
        let file = file_for_xml(Path::new(""), &m.path.to_string_lossy(), Some(dir));
        let _ = writeln!(
            x,
            "    <emitter type=\"envmap\">\n        <string name=\"filename\" value=\"{}\"/>",
            attr(&file)
        );
        if m.scale != 1.0 {
            let _ = writeln!(x, "        <float name=\"scale\" value=\"{}\"/>", m.scale);
        }
        if m.to_world != glam::Mat3::IDENTITY {
            let r = m.to_world;
            let v: Vec<String> = (0..3)
                .flat_map(|i| {
                    let row = r.row(i);
                    [row.x, row.y, row.z, 0.0].map(|c| c.to_string())
                })
                .chain(["0", "0", "0", "1"].map(String::from))
                .collect();
            let _ = writeln!(
                x,
                "        <transform name=\"to_world\">\n            <matrix value=\"{}\"/>\n        </transform>",
                v.join(" ")
            );
        }
        x.push_str("    </emitter>\n");
    }
    for l in &s.lights {
        x.push_str(&match l {
            DeltaLight::Point {
                position: p,
                intensity,
            } => format!(
                "    <emitter type=\"point\">\n        <point name=\"position\" x=\"{}\" y=\"{}\" z=\"{}\"/>\n        <rgb name=\"intensity\" value=\"{}\"/>\n    </emitter>\n",
                p.x, p.y, p.z, rgb(*intensity)
            ),
            DeltaLight::Directional {
                direction: d,
                irradiance,
            } => format!(
                "    <emitter type=\"directional\">\n        <vector name=\"direction\" x=\"{}\" y=\"{}\" z=\"{}\"/>\n        <rgb name=\"irradiance\" value=\"{}\"/>\n    </emitter>\n",
                d.x, d.y, d.z, rgb(*irradiance)
            ),
        });
    }
    let mut meshes = Vec::new();
    for shape in ordered_shapes(s) {
        match shape {
            Shape::Mesh(tris) => {
                let file = format!("{mesh_dir}/mesh-{}.obj", meshes.len());
                let (t, a) = tris[0];
                let _ = writeln!(x, "    <shape type=\"obj\">");
                let _ = writeln!(
                    x,
                    "        <string name=\"filename\" value=\"{}\"/>",
                    attr(&file)
                );
                if a.n.is_none() {
                    // The OBJ shares vertices (obj_text): without this, Mitsuba would make
                    // smooth normals over them where brdfwave shades the flat triangles.
                    let _ = writeln!(x, "        <boolean name=\"face_normals\" value=\"true\"/>");
                }
                shape_tail(&mut x, s, &ids, t.material, t.emitter);
                meshes.push((file, obj_text(&tris)));
            }
            Shape::Sphere(sp) => {
                let _ = writeln!(x, "    <shape type=\"sphere\">");
                let c = sp.center;
                let _ = writeln!(
                    x,
                    "        <point name=\"center\" x=\"{}\" y=\"{}\" z=\"{}\"/>",
                    c.x, c.y, c.z
                );
                let _ = writeln!(
                    x,
                    "        <float name=\"radius\" value=\"{}\"/>",
                    sp.radius
                );
                // A turned sphere turns its texture coordinates: Mitsuba's `to_world` applies
                // after `center` and `radius`, so the turn about the centre is
                // T(c)·R·T(−c). A mirroring R turns Mitsuba's sphere inward, which
                // flip_normals undoes where brdfwave's is not.
                let mirror = sp.frame.is_some_and(|f| f.mirror);
                if sp.inward != mirror {
                    let _ = writeln!(x, "        <boolean name=\"flip_normals\" value=\"true\"/>");
                }
                if let Some(f) = sp.frame {
                    let _ = writeln!(
                        x,
                        "        <transform name=\"to_world\"><matrix value=\"{}\"/></transform>",
                        sphere_turn(f, c)
                    );
                }
                shape_tail(&mut x, s, &ids, sp.material, sp.emitter);
            }
        }
    }
    x.push_str("</scene>\n");
    // Mitsuba substitutes `$name` in every attribute value and has no escape for '$'; the ids
    // have none (`bsdf_ids`), so a '$' left is a file's.
    let values = x
        .split("value=\"")
        .skip(1)
        .chain(meshes.iter().map(|(f, _)| f.as_str()));
    if let Some(v) = values
        .map(|v| v.split('"').next().unwrap_or(v))
        .find(|v| v.contains('$'))
    {
        return Err(format!(
            "the path '{v}' holds a '$', which Mitsuba 3 reads as the start of a parameter ($name) and has no escape for: rename the file or folder (or the output) so that its path has none"
        ));
    }
    Ok(Converted { xml: x, meshes })
}

/// The XML ids of the materials `names`: each name as it is, unless Mitsuba cannot take it as
/// an id (empty, or holding a '$', which Mitsuba reads as a parameter); those become
/// `material<i>`. Each id is made unique by trailing underscores.
fn bsdf_ids(names: &[String]) -> Vec<String> {
    let mut ids: Vec<String> = Vec::with_capacity(names.len());
    for (i, n) in names.iter().enumerate() {
        let mut id = match n.is_empty() || n.contains('$') {
            true => format!("material{i}"),
            false => n.clone(),
        };
        while ids.contains(&id) || (id != *n && names.contains(&id)) {
            id.push('_');
        }
        ids.push(id);
    }
    ids
}

/// A two-sided material: its BSDF element (`b`, as [`bsdf`] writes it) nested, without its id,
/// in a `twosided` BSDF that takes the id.
/// A file named by the scene (a measured table, an image; `given` relative to the scene file's
/// directory `s_dir`), as the XML in `xml_dir` must name it: relative to `xml_dir` when the two
/// share a directory below the root (`../material-preview/studio.hdr` from `scenes/xml/`, so
/// that the pair moves together), else absolute.
fn file_for_xml(s_dir: &Path, given: &str, xml_dir: Option<&Path>) -> String {
    use std::path::Component;
    let full = s_dir.join(given);
    let full = full.canonicalize().unwrap_or(full);
    let full = std::path::absolute(&full).unwrap_or(full);
    let dir = xml_dir.unwrap_or(s_dir);
    let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
    let dir = std::path::absolute(&dir).unwrap_or(dir);
    let (a, b): (Vec<Component>, Vec<Component>) =
        (full.components().collect(), dir.components().collect());
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let shares = a[..common]
        .iter()
        .any(|c| matches!(c, Component::Normal(_)));
    if !shares {
        return full.to_string_lossy().into_owned();
    }
    let mut p = PathBuf::new();
    for _ in common..b.len() {
        p.push("..");
    }
    for c in &a[common..] {
        p.push(c);
    }
    p.to_string_lossy().into_owned()
}

fn twosided(b: &str, id: &str) -> String {
    let id = format!(" id=\"{}\"", attr(id));
    let inner: String = b
        .replacen(&id, "", 1)
        .lines()
        .map(|l| format!("    {l}\n"))
        .collect();
    format!("    <bsdf type=\"twosided\"{id}>\n{inner}    </bsdf>\n")
}

/// Text safe inside a double-quoted XML attribute.
fn attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn rgb(c: Vec3) -> String {
    format!("{}, {}, {}", c.x, c.y, c.z)
}

fn integrator(x: &mut String, s: &Scene) {
    let i = &s.integrator;
    // Mitsuba's roulette is always on from rr_depth: off is an rr_depth it never reaches.
    let rr = if i.russian_roulette {
        i.rr_start_depth
    } else {
        i.max_depth
    };
    let hide = match i.hide_emitters {
        true => "\n        <boolean name=\"hide_emitters\" value=\"true\"/>",
        false => "",
    };
    let _ = writeln!(
        x,
        "    <integrator type=\"path\">\n        <integer name=\"max_depth\" value=\"{}\"/>\n        <integer name=\"rr_depth\" value=\"{rr}\"/>{hide}\n    </integrator>",
        i.max_depth
    );
}

fn sensor(x: &mut String, s: &Scene) {
    let c = &s.camera;
    // The multi-jittered sampler as Mitsuba's own (the same construction, Kensler 2013), and
    // the Sobol' sampler as `multijitter` too, not `ldsampler`: Mitsuba 3.9.1's `ldsampler`
    // converges to a wrong image where light bounces (a quad lit only by the floor beside it
    // renders 1.7–3.7 % dark at 2,048 and at 8,192 spp alike), where `multijitter`,
    // `stratified` and `independent` agree with brdfwave within 0.3 %.
    let sampler = match s.integrator.sampler {
        crate::rng::Sampler::Independent => "independent",
        _ => "multijitter",
    };
    // A thin lens as Mitsuba's `thinlens` (the same lens: the plane through the position
    // perpendicular to the view, focused on the plane at focus_distance).
    let (kind, lens) = match c.aperture_radius > 0.0 {
        true => (
            "thinlens",
            format!(
                "\n        <float name=\"aperture_radius\" value=\"{}\"/>\n        <float name=\"focus_distance\" value=\"{}\"/>",
                c.aperture_radius, c.focus_distance
            ),
        ),
        false => ("perspective", String::new()),
    };
    let _ = write!(
        x,
        "    <sensor type=\"{kind}\">{lens}
        <float name=\"fov\" value=\"{}\"/>
        <string name=\"fov_axis\" value=\"y\"/>
        <transform name=\"to_world\">
            {}<lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>
        </transform>
        <sampler type=\"{sampler}\">
            <integer name=\"sample_count\" value=\"{}\"/>
            <integer name=\"seed\" value=\"{}\"/>
        </sampler>
        <film type=\"hdrfilm\">
            <integer name=\"width\" value=\"{}\"/>
            <integer name=\"height\" value=\"{}\"/>
            <rfilter type=\"box\"/>
        </film>
    </sensor>
",
        c.fov_y_deg,
        // A mirrored image: the camera's x turned over before the lookat places it.
        if c.mirror { "<scale x=\"-1\"/>" } else { "" },
        rgb(c.position),
        rgb(c.target),
        rgb(c.up),
        s.integrator.spp,
        s.integrator.seed,
        s.width,
        s.height
    );
}

/// A top-level `<bsdf id="ID">` of the material `name`.
fn bsdf(
    m: &crate::brdf::Material,
    (name, id): (&str, &str),
    params: Option<&std::collections::BTreeMap<String, toml::Value>>,
    opts: &Options,
    s_dir: &Path,
) -> Result<String, String> {
    let id = attr(id);
    let any = m.brdf.as_any();
    let xml_dir = opts.xml_dir.as_deref().unwrap_or(s_dir);
    // A textured parameter as a nested bitmap under Mitsuba's name for it.
    let texture = |ours: &str, theirs: &str| {
        m.textures
            .iter()
            .find(|t| t.param.name == ours)
            .map(|t| bitmap(&t.texture, theirs, xml_dir))
    };
    if let Some(l) = any.downcast_ref::<Lambert>() {
        let reflectance = texture("albedo", "reflectance").unwrap_or_else(|| {
            format!(
                "        <rgb name=\"reflectance\" value=\"{}\"/>\n",
                rgb(l.albedo)
            )
        });
        return Ok(format!(
            "    <bsdf type=\"diffuse\" id=\"{id}\">\n{reflectance}    </bsdf>\n"
        ));
    }
    if let Some(c) = any.downcast_ref::<CookTorrance>() {
        // Mitsuba's plugins take textures for these three only.
        let twins = ["kd", "ks", "roughness"];
        if m.textures.iter().all(|t| twins.contains(&t.param.name)) {
            if let Some(b) = cook_torrance(c, &id, &texture) {
                return Ok(b);
            }
        }
    }
    let why = format!(
        "material '{name}' ({}) has no Mitsuba 3 twin: Mitsuba takes Lambert (diffuse) and Cook–Torrance \
         with normalization = \"walter\" and geometry = \"smith\" (roughconductor: conductor Fresnel, or \
         schlick with f0 = 1, and kd = 0; roughplastic: dielectric Fresnel, its roughness a number, not a \
         texture); --brdfwave-plugins writes \
         it under brdfwave's own plugin name, which only brdfwave reads",
        m.model_name()
    );
    if !opts.brdfwave_plugins {
        return Err(why);
    }
    let Some(params) = params else {
        return Err(format!("material '{name}': its parameters are not known"));
    };
    let mut b = format!("    <bsdf type=\"{}\" id=\"{id}\">\n", m.model_name());
    for (k, v) in params.iter().filter(|(k, _)| *k != "model") {
        let k = attr(k);
        let line = match v {
            toml::Value::Table(_) => match texture(&k, &k) {
                Some(b) => b.trim().to_string(),
                None => return Err(format!("material '{name}', '{k}': not a texture")),
            },
            toml::Value::Float(f) => format!("<float name=\"{k}\" value=\"{}\"/>", *f as f32),
            toml::Value::Integer(i) => format!("<integer name=\"{k}\" value=\"{i}\"/>"),
            toml::Value::Boolean(t) => format!("<boolean name=\"{k}\" value=\"{t}\"/>"),
            toml::Value::String(t) if crate::brdf::is_file_param(m.model_name(), &k) => format!(
                "<string name=\"{k}\" value=\"{}\"/>",
                attr(&file_for_xml(s_dir, t, opts.xml_dir.as_deref()))
            ),
            toml::Value::String(t) => format!("<string name=\"{k}\" value=\"{}\"/>", attr(t)),
            toml::Value::Array(a) if a.len() == 3 => {
                let n: Vec<String> = a
                    .iter()
                    .map(|e| match e {
                        toml::Value::Float(f) => format!("{}", *f as f32),
                        toml::Value::Integer(i) => format!("{}", *i as f32),
                        _ => String::new(),
                    })
                    .collect();
                if n.iter().any(String::is_empty) {
                    return Err(format!("material '{name}', '{k}': not an RGB colour"));
                }
                format!("<rgb name=\"{k}\" value=\"{}\"/>", n.join(", "))
            }
            _ => {
                return Err(format!(
                    "material '{name}', '{k}': this value cannot be written as XML"
                ))
            }
        };
        let _ = writeln!(b, "        {line}");
    }
    b.push_str("    </bsdf>\n");
    Ok(b)
}

/// A texture as Mitsuba's `bitmap` named `name`, its file relative to `xml_dir` when below
/// it (its lines, indented for a BSDF's parameter). `to_uv` goes as the 4×4 matrix whose rows
/// and columns 0, 1, 3 are the 2-D map (what Mitsuba takes from a 4×4 `to_uv`).
fn bitmap(t: &crate::texture::Texture, name: &str, xml_dir: &Path) -> String {
    let file = file_for_xml(Path::new(""), &t.path.to_string_lossy(), Some(xml_dir));
    let mut b = format!(
        "        <texture type=\"bitmap\" name=\"{}\">\n            <string name=\"filename\" value=\"{}\"/>\n",
        attr(name),
        attr(&file)
    );
    if t.raw {
        b += "            <boolean name=\"raw\" value=\"true\"/>\n";
    }
    if t.filter != crate::texture::Filter::Bilinear {
        let _ = writeln!(
            b,
            "            <string name=\"filter_type\" value=\"{}\"/>",
            t.filter.name()
        );
    }
    if t.wrap != crate::texture::Wrap::Repeat {
        let _ = writeln!(
            b,
            "            <string name=\"wrap_mode\" value=\"{}\"/>",
            t.wrap.name()
        );
    }
    if t.to_uv != crate::texture::IDENTITY_UV {
        let [r0, r1] = t.to_uv;
        let _ = writeln!(
            b,
            "            <transform name=\"to_uv\">\n                <matrix value=\"{} {} 0 {} {} {} 0 {} 0 0 1 0 0 0 0 1\"/>\n            </transform>",
            r0[0], r0[1], r0[2], r1[0], r1[1], r1[2]
        );
    }
    b += "        </texture>\n";
    b
}

/// Cook–Torrance as `(rough)conductor` or `(rough)plastic`, when it is one; `texture(ours,
/// theirs)` is the bitmap of a textured parameter.
fn cook_torrance(
    c: &CookTorrance,
    id: &str,
    texture: &dyn Fn(&str, &str) -> Option<String>,
) -> Option<String> {
    if c.normalization != Normalization::Walter || c.geometry != Geometry::Smith {
        return None;
    }
    // Mitsuba's roughplastic takes a number for alpha, not a texture.
    if c.fresnel == Fresnel::Dielectric && texture("roughness", "alpha").is_some() {
        return None;
    }
    // A rough plugin with α = 0 would divide by zero in Mitsuba: zero is the smooth plugin.
    let rough = c.roughness > 0.0;
    let mut p = String::new();
    if rough {
        let d = match c.distribution {
            Distribution::Beckmann => "beckmann",
            Distribution::Ggx => "ggx",
        };
        let _ = writeln!(p, "        <string name=\"distribution\" value=\"{d}\"/>");
        match texture("roughness", "alpha") {
            Some(b) => p += &b,
            None => {
                let _ = writeln!(
                    p,
                    "        <float name=\"alpha\" value=\"{}\"/>",
                    c.roughness
                );
            }
        }
    }
    if let Some(b) = texture("ks", "specular_reflectance") {
        p += &b;
    } else if c.ks != Vec3::ONE {
        let _ = writeln!(
            p,
            "        <rgb name=\"specular_reflectance\" value=\"{}\"/>",
            rgb(c.ks)
        );
    }
    let kind = match c.fresnel {
        Fresnel::Conductor if c.kd == Vec3::ZERO => {
            let _ = writeln!(p, "        <rgb name=\"eta\" value=\"{}\"/>", rgb(c.eta));
            let _ = writeln!(p, "        <rgb name=\"k\" value=\"{}\"/>", rgb(c.k));
            "conductor"
        }
        Fresnel::Schlick if c.kd == Vec3::ZERO && c.f0 == Vec3::ONE => {
            let _ = writeln!(p, "        <string name=\"material\" value=\"none\"/>");
            "conductor"
        }
        Fresnel::Dielectric => {
            match texture("kd", "diffuse_reflectance") {
                Some(b) => p += &b,
                None => {
                    let _ = writeln!(
                        p,
                        "        <rgb name=\"diffuse_reflectance\" value=\"{}\"/>",
                        rgb(c.kd)
                    );
                }
            }
            let _ = writeln!(p, "        <float name=\"int_ior\" value=\"{}\"/>", c.ior);
            let _ = writeln!(p, "        <float name=\"ext_ior\" value=\"1\"/>");
            "plastic"
        }
        _ => return None,
    };
    let kind = if rough {
        format!("rough{kind}")
    } else {
        kind.to_string()
    };
    Some(format!(
        "    <bsdf type=\"{kind}\" id=\"{id}\">\n{p}    </bsdf>\n"
    ))
}

/// A shape's `<ref>` (to its material's id, of `ids`), emitter and end tag.
fn shape_tail(x: &mut String, s: &Scene, ids: &[String], material: u32, emitter: Option<u32>) {
    let id = ids.get(material as usize).map_or("", String::as_str);
    let _ = writeln!(x, "        <ref id=\"{}\"/>", attr(id));
    if let Some(e) = emitter.and_then(|e| s.emitters.get(e as usize)) {
        let _ = writeln!(
            x,
            "        <emitter type=\"area\">\n            <rgb name=\"radiance\" value=\"{}\"/>\n        </emitter>",
            rgb(e.radiance)
        );
    }
    x.push_str("    </shape>\n");
}

enum Shape<'s> {
    /// Triangles with their vertex attributes.
    Mesh(Vec<(&'s Triangle, VertexAttributes)>),
    Sphere(&'s Sphere),
}

/// The shapes to write: runs of triangles with one material and emitter (and all or none with normals, texture
/// coordinates), and the spheres, in
/// an order that keeps the triangles' order, the spheres' order and the emitters' numbering
/// (the loader numbers emitters in shape order).
fn ordered_shapes(s: &Scene) -> Vec<Shape<'_>> {
    // An OBJ object's vertices all have normals (texture coordinates) or none do.
    let key = |(t, a): (&Triangle, VertexAttributes)| {
        (t.material, t.emitter, a.n.is_some(), a.uv.is_some())
    };
    let mut runs: Vec<Vec<(&Triangle, VertexAttributes)>> = Vec::new();
    for (i, t) in s.triangles.iter().enumerate() {
        let ta = (t, s.attributes_of(i));
        match runs.last_mut() {
            Some(r) if key(r[0]) == key(ta) => r.push(ta),
            _ => runs.push(vec![ta]),
        }
    }
    let (mut runs, mut spheres) = (runs.into_iter().peekable(), s.spheres.iter().peekable());
    let mut out = Vec::new();
    loop {
        let next_run = runs.peek().map(|r| r[0].0.emitter);
        let next_sphere = spheres.peek().map(|sp| sp.emitter);
        let take_run = match (next_run, next_sphere) {
            (None, None) => break,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (Some(None), _) => true,
            (_, Some(None)) => false,
            (Some(Some(a)), Some(Some(b))) => a < b,
        };
        if take_run {
            out.extend(runs.next().map(Shape::Mesh));
        } else {
            out.extend(spheres.next().map(Shape::Sphere));
        }
    }
    out
}

/// An OBJ of the triangles, every number exact. Equal positions (normals, texture coordinates)
/// are written once and shared, as an indexed mesh: the file is about a third of one with
/// three vertices per triangle, and Mitsuba loads it that much faster. Sharing changes no
/// triangle (each corner keeps its own bits); a mesh without normals is marked `face_normals`
/// (see [`to_mitsuba`]), so Mitsuba does not smooth it over the shared vertices.
fn obj_text(tris: &[(&Triangle, VertexAttributes)]) -> String {
    use std::collections::HashMap;
    /// Index (1-based) of `v` in `list`, adding it if new; keyed on the bits of its numbers.
    fn index<const N: usize>(
        map: &mut HashMap<[u32; N], usize>,
        list: &mut Vec<[f32; N]>,
        v: [f32; N],
    ) -> usize {
        *map.entry(v.map(f32::to_bits)).or_insert_with(|| {
            list.push(v);
            list.len()
        })
    }
    let (mut vs, mut ns, mut ts) = (Vec::new(), Vec::new(), Vec::new());
    let (mut vm, mut nm, mut tm) = (HashMap::new(), HashMap::new(), HashMap::new());
    let mut faces = String::new();
    for (t, a) in tris {
        // brdfwave's front is the winding's side, and it shades with the normals only where
        // they point to it; Mitsuba's front is where the normals point. A triangle with a
        // normal behind it is written with its face normal: where all three are behind, as in
        // a mirrored mesh, that is what brdfwave shades with.
        let ng = t.geometric_normal();
        let n = a.n.map(|n| match n.iter().any(|n| n.dot(ng) <= 0.0) {
            true => [ng; 3],
            false => n,
        });
        let mut f = String::from("f");
        for k in 0..3 {
            let vi = index(&mut vm, &mut vs, t.v[k].to_array());
            let ti = a.uv.map(|uv| index(&mut tm, &mut ts, uv[k].to_array()));
            let ni = n.map(|n| index(&mut nm, &mut ns, n[k].to_array()));
            let _ = match (ti, ni) {
                (None, None) => write!(f, " {vi}"),
                (Some(ti), None) => write!(f, " {vi}/{ti}"),
                (None, Some(ni)) => write!(f, " {vi}//{ni}"),
                (Some(ti), Some(ni)) => write!(f, " {vi}/{ti}/{ni}"),
            };
        }
        faces.push_str(&f);
        faces.push('\n');
    }
    let mut o = String::from("# Written by `brdfwave convert`: world space, exact f32 values.\n");
    for v in &vs {
        let _ = writeln!(o, "v {} {} {}", v[0], v[1], v[2]);
    }
    for n in &ns {
        let _ = writeln!(o, "vn {} {} {}", n[0], n[1], n[2]);
    }
    // Texture coordinates are kept with v down from the image's top; OBJ's v runs up (the
    // reader flips it back, exactly for v in [0, 1]).
    for t in &ts {
        let _ = writeln!(o, "vt {} {}", t[0], 1.0 - t[1]);
    }
    o.push_str(&faces);
    o
}

/// The 4×4 matrix, row by row, that turns a sphere centred at `c` by the inverse of its
/// frame's `W` (`R = Wᵀ`; `W` is `crate::scene::SphereFrame::to_local`) about its centre:
/// T(c)·R·T(−c).
fn sphere_turn(f: crate::scene::SphereFrame, c: glam::Vec3) -> String {
    // W's columns are the frame's images of the axes; R = Wᵀ.
    let w = [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z].map(|e| f.to_local(e).as_dvec3());
    let r = glam::DMat3::from_cols(w[0], w[1], w[2]).transpose();
    let c = c.as_dvec3();
    let t = c - r * c;
    let rows = [
        [r.x_axis.x, r.y_axis.x, r.z_axis.x, t.x],
        [r.x_axis.y, r.y_axis.y, r.z_axis.y, t.y],
        [r.x_axis.z, r.y_axis.z, r.z_axis.z, t.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    rows.iter()
        .flatten()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::file_for_xml;
    use std::path::Path;

    /// A file beside or above the XML's folder is named through `..`; one that shares nothing
    /// with it below the root, absolutely.
    #[test]
    fn files_are_named_from_the_xml_folder() {
        let name = |file: &str, dir: &str| file_for_xml(Path::new(""), file, Some(Path::new(dir)));
        assert_eq!(name("/nowhere-a/b/c.png", "/nowhere-a/b"), "c.png");
        assert_eq!(
            name("/nowhere-a/m/c.png", "/nowhere-a/b/xml"),
            "../../m/c.png"
        );
        assert_eq!(
            name("/nowhere-a/c.png", "/nowhere-z/xml"),
            "/nowhere-a/c.png"
        );
    }
}
