//! The `self_shadow` group: rays that leave a surface must not find it, or the light they aim
//! at, where there is nothing (false occlusion), and must find what is there (no leaks). The
//! mechanism under test is stated in the [`crate::robust`] module documentation ("Every ray
//! that leaves a surface").
//!
//! Each case builds one scene file through one of the four readers (TOML, OBJ, PLY, Mitsuba
//! XML), with one shape placed at a random scale, rotation and offset, renders it with direct
//! light only (`max_depth` 2) on both backends, and compares with an analytic answer:
//!
//! * **Lone shape** (a quad, a disk as a fan of triangles, a cube, an icosphere or an analytic
//!   sphere, the sphere sometimes huge with the camera just above it, like a ground): nothing
//!   can block any ray that leaves it towards the side it is seen from, since it is flat or
//!   convex. Under a uniform sky every sample that hits the shape is worth exactly
//!   albedo × radiance (a Lambert surface, cosine-sampled, no light sampling), so the number
//!   of samples that lost their light is read off the image, against a `max_depth` 1 render
//!   of the same camera rays that says which samples hit the shape. Under a point light, a
//!   directional light or an area light (a small emitting sphere or quad in front of the
//!   shape), every shadow ray must come through: the renderers count those that found an
//!   occluder ([`crate::output::RenderOutput::shadow_rays_occluded`]), and that must be 0.
//!   Two-sided shapes are sometimes seen, and lit, from behind.
//! * **Closed room** (a cube, an icosphere or a sphere seen from inside): every light is
//!   outside (a sky, a point, a directional or an emitting sphere), so every pixel must be
//!   exactly black; a pixel that is not is a leak.
//!
//! Scales run from 1e-4 to 1e4 (spheres 1e-4 to 1e7), offsets up to 1e5 (sphere centres up
//! to 1e7), at most 1e4 times the scale (beyond that single precision cannot place the shape's
//! points, and the loader refuses spheres: `robust::sphere_precision_problem`).

use super::harness::{backend_name, render_on, CaseResult, Env};
use super::rng::Rng;
use crate::scene::Scene;
use anyhow::{Context as _, Result};
use glam::{DMat3, DVec3};
use std::fmt::Write as _;
use std::path::Path;

/// The albedo of every shape (a Lambert material).
const ALBEDO: f64 = 0.5;
/// Image size and samples per pixel of each render.
const RES: u32 = 24;
const SPP: u32 = 4;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Quad,
    Disk,
    Cube,
    Icosphere,
    Sphere,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Reader {
    Toml,
    Obj,
    Ply,
    Xml,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Light {
    Sky,
    Point,
    Directional,
    AreaSphere,
    AreaQuad,
}

/// One case, drawn from its seed.
#[derive(Debug)]
struct Case {
    shape: Shape,
    reader: Reader,
    light: Light,
    /// A closed shape seen from inside, every light outside.
    room: bool,
    twosided: bool,
    /// A two-sided flat shape seen (and lit) from behind.
    back: bool,
    /// The shape's transform is given to the reader (else its vertices are written in world
    /// space).
    by_transform: bool,
    scale: f64,
    offset: DVec3,
    axis: DVec3,
    angle_deg: f64,
    /// A sphere seen from just above its surface (`height` above it, in units of its radius).
    ground: Option<f64>,
    /// Directions in the shape's own frame: to the camera, to the light.
    to_camera: DVec3,
    to_light: DVec3,
    seed: u32,
}

impl Case {
    fn draw(r: &mut Rng, seed: u64) -> Case {
        let room = r.next_u64() % 4 == 0;
        let shape = if room {
            *r.pick(&[Shape::Cube, Shape::Icosphere, Shape::Sphere])
        } else {
            *r.pick(&[
                Shape::Quad,
                Shape::Disk,
                Shape::Cube,
                Shape::Icosphere,
                Shape::Sphere,
            ])
        };
        let reader = *r.pick(&[Reader::Toml, Reader::Obj, Reader::Ply, Reader::Xml]);
        let light = if room {
            *r.pick(&[
                Light::Sky,
                Light::Point,
                Light::Directional,
                Light::AreaSphere,
            ])
        } else {
            *r.pick(&[
                Light::Sky,
                Light::Point,
                Light::Directional,
                Light::AreaSphere,
                Light::AreaQuad,
            ])
        };
        let flat = matches!(shape, Shape::Quad | Shape::Disk);
        let twosided = room || r.next_u64() % 3 == 0;
        let back = flat && twosided && r.next_u64() % 2 == 0;
        let sphere = shape == Shape::Sphere && reader != Reader::Obj && reader != Reader::Ply;
        let scale = if sphere {
            r.log_range(1e-4, 1e7) as f64
        } else {
            r.log_range(1e-4, 1e4) as f64
        };
        let reach = if sphere { 1e7 } else { 1e5 };
        let offset = if r.next_u64() % 4 == 0 {
            DVec3::ZERO
        } else {
            let m = r.log_range(1e-3, 1e4) as f64 * scale;
            random_dir(r) * m.min(reach)
        };
        let ground = (sphere && !room && r.next_u64() % 3 == 0).then(|| {
            // At least 16 float steps of the radius above the surface.
            let steps = 16.0 * crate::robust::ulp(scale as f32) as f64 / scale;
            (r.log_range(1e-6, 1e-1) as f64).max(steps)
        });
        let area = matches!(light, Light::AreaSphere | Light::AreaQuad);
        // A ground sphere is lit by a point or directional light (an emitter that small beside
        // the huge sphere's coordinates could not be placed).
        let light = if ground.is_some() && area {
            Light::Point
        } else {
            light
        };
        // Directions in the shape's frame: a flat shape is seen from its front (+z) half,
        // down to grazing views; a closed one from anywhere.
        // (An area light well above the shape's plane, so that it does not cut it.)
        let front = |r: &mut Rng, min_z: f64| {
            let d = random_dir(r);
            let z = d.z.abs().max(min_z);
            DVec3::new(d.x, d.y, z).normalize()
        };
        let (to_camera, to_light) = if flat {
            (front(r, 0.03), front(r, if area { 0.3 } else { 0.03 }))
        } else {
            (random_dir(r), random_dir(r))
        };
        let axis = random_dir(r);
        let angle_deg = r.range(0.0, 360.0) as f64;
        // A ground sphere's top passes near the world origin, where users put their cameras.
        let offset = if ground.is_some() {
            -(DMat3::from_axis_angle(axis, angle_deg.to_radians()) * to_camera) * scale
        } else {
            offset
        };
        Case {
            shape,
            reader,
            light,
            room,
            twosided,
            back,
            by_transform: r.next_u64() % 2 == 0,
            scale,
            offset,
            axis,
            angle_deg,
            ground,
            to_camera,
            to_light,
            seed: (seed & 0xffff_ffff) as u32,
        }
    }

    fn rotation(&self) -> DMat3 {
        DMat3::from_axis_angle(self.axis, self.angle_deg.to_radians())
    }

    /// A point of the shape's frame in world space: scaled, rotated, then moved (the order of
    /// the TOML `transform` and of the XML `to_world` written below).
    fn world(&self, p: DVec3) -> DVec3 {
        self.offset + self.rotation() * (p * self.scale)
    }

    /// A direction of the shape's frame in world space, for a seen-from-behind case mirrored.
    fn world_dir(&self, d: DVec3) -> DVec3 {
        let d = if self.back {
            DVec3::new(d.x, d.y, -d.z)
        } else {
            d
        };
        self.rotation() * d
    }

    fn describe(&self) -> String {
        let mut s = format!(
            "{:?} {} via {:?}, {:?} light, scale {:e}, offset {:?}, rotation {:.1} deg about {:?}",
            self.shape,
            if self.room { "room" } else { "alone" },
            self.reader,
            self.light,
            self.scale,
            self.offset.to_array(),
            self.angle_deg,
            self.axis.to_array(),
        );
        if self.twosided {
            s += ", two-sided";
        }
        if self.back {
            s += ", seen from behind";
        }
        if let Some(h) = self.ground {
            let _ = write!(s, ", camera {h:e} radii above the surface");
        }
        s += if self.by_transform {
            ", placed by the reader's transform"
        } else {
            ", vertices in world space"
        };
        s
    }
}

fn random_dir(r: &mut Rng) -> DVec3 {
    loop {
        let v = DVec3::new(
            r.f64() * 2.0 - 1.0,
            r.f64() * 2.0 - 1.0,
            r.f64() * 2.0 - 1.0,
        );
        let l = v.length();
        if l > 1e-3 && l <= 1.0 {
            return v / l;
        }
    }
}

/// Any unit vector not parallel to `d`.
fn not_parallel(d: DVec3) -> DVec3 {
    if d.x.abs() < 0.6 {
        DVec3::X
    } else {
        DVec3::Y
    }
}

/// The shape's triangles in its own frame (unit size, centred at the origin; flat shapes in
/// z = 0 facing +z, closed ones facing out), for the mesh readers and TOML `triangles`.
fn shape_mesh(shape: Shape) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    match shape {
        Shape::Quad => (
            vec![
                DVec3::new(-1.0, -1.0, 0.0),
                DVec3::new(1.0, -1.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(-1.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        ),
        Shape::Disk => {
            let n = 64;
            let mut v = vec![DVec3::ZERO];
            for i in 0..n {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                v.push(DVec3::new(a.cos(), a.sin(), 0.0));
            }
            let f = (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
            (v, f)
        }
        Shape::Cube => {
            let v: Vec<DVec3> = (0..8)
                .map(|i| {
                    DVec3::new(
                        if i & 1 != 0 { 1.0 } else { -1.0 },
                        if i & 2 != 0 { 1.0 } else { -1.0 },
                        if i & 4 != 0 { 1.0 } else { -1.0 },
                    )
                })
                .collect();
            // Faces counter-clockwise seen from outside.
            let quads = [
                [0, 2, 3, 1], // -z
                [4, 5, 7, 6], // +z
                [0, 1, 5, 4], // -y
                [2, 6, 7, 3], // +y
                [0, 4, 6, 2], // -x
                [1, 3, 7, 5], // +x
            ];
            let f = quads
                .iter()
                .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
                .collect();
            (v, f)
        }
        Shape::Icosphere | Shape::Sphere => {
            let (v, f) = crate::scene::shapes::icosphere(2, glam::Vec3::ZERO, 1.0);
            (v.iter().map(|p| p.as_dvec3()).collect(), f)
        }
    }
}

/// Numbers as written to the files: the shortest text that reads back to the same f64.
fn num(x: f64) -> String {
    format!("{x:e}")
}
fn vec3(v: DVec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

/// The case's scene file (and mesh files) in `dir`, rendering with `max_depth`.
fn write_scene(c: &Case, dir: &Path, max_depth: u32) -> Result<std::path::PathBuf> {
    let rot = c.rotation();
    // The shape's extent: a bounding radius.
    let bound = c.scale
        * match c.shape {
            Shape::Cube => 3f64.sqrt(),
            Shape::Quad => 2f64.sqrt(),
            _ => 1.0,
        };
    // Camera and light, in world space.
    let center = c.offset;
    let (cam, target, up, fov) = if c.room {
        let cam = center + rot * (random_inside(c) * c.scale);
        let look = c.world_dir(c.to_camera);
        (cam, cam + look * c.scale, not_parallel(look), 70.0)
    } else if let Some(h) = c.ground {
        let u = c.world_dir(c.to_camera);
        let cam = center + u * (c.scale * (1.0 + h));
        let w = u.cross(not_parallel(u)).normalize();
        let target = center + (u + w * (h * 4.0)).normalize() * c.scale;
        (cam, target, u, 60.0)
    } else {
        let d = c.world_dir(c.to_camera);
        let dist = bound * 3.0;
        let fov = 2.0 * (1.3 * bound / dist).atan().to_degrees();
        (center + d * dist, center, not_parallel(d), fov)
    };
    let light_dir = c.world_dir(c.to_light);
    let light_pos = if let Some(h) = c.ground {
        // Above the surface near the camera.
        let u = c.world_dir(c.to_camera);
        center + (u + light_dir * (h * 2.0)).normalize() * (c.scale * (1.0 + 3.0 * h))
    } else {
        center + light_dir * (bound * 2.5)
    };
    // At least 300 float steps at its centre (the loader refuses smaller spheres).
    let steps = 300.0 * crate::robust::ulp(light_pos.abs().max_element() as f32) as f64;
    let emitter_radius = (bound * 0.1).max(steps);

    let env = if c.light == Light::Sky { 1.0 } else { 0.0 };
    let (mesh_v, mesh_f) = shape_mesh(c.shape);
    // Rooms face inwards.
    let faces: Vec<[usize; 3]> = if c.room {
        mesh_f.iter().map(|f| [f[0], f[2], f[1]]).collect()
    } else {
        mesh_f.clone()
    };
    let placed: Vec<DVec3> = if c.by_transform {
        mesh_v.clone()
    } else {
        mesh_v.iter().map(|&p| c.world(p)).collect()
    };
    let mesh_file = |ext: &str| -> Result<String> {
        let name = format!("shape.{ext}");
        let text = match ext {
            "obj" => {
                let mut t = String::new();
                for p in &placed {
                    let _ = writeln!(t, "v {} {} {}", num(p.x), num(p.y), num(p.z));
                }
                for f in &faces {
                    let _ = writeln!(t, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
                }
                t
            }
            _ => {
                let mut t = format!(
                    "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
                     property float z\nelement face {}\nproperty list uchar int vertex_indices\n\
                     end_header\n",
                    placed.len(),
                    faces.len()
                );
                for p in &placed {
                    let _ = writeln!(t, "{} {} {}", num(p.x), num(p.y), num(p.z));
                }
                for f in &faces {
                    let _ = writeln!(t, "3 {} {} {}", f[0], f[1], f[2]);
                }
                t
            }
        };
        std::fs::write(dir.join(&name), text)?;
        Ok(name)
    };

    let path;
    match c.reader {
        Reader::Xml => {
            let mut x = String::from("<scene version=\"3.0.0\">\n");
            let _ = writeln!(
                x,
                "<integrator type=\"path\"><integer name=\"max_depth\" value=\"{max_depth}\"/></integrator>"
            );
            let _ = writeln!(
                x,
                "<sensor type=\"perspective\"><float name=\"fov\" value=\"{fov}\"/><string name=\"fov_axis\" value=\"y\"/>\
                 <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>\
                 <sampler type=\"independent\"><integer name=\"sample_count\" value=\"{SPP}\"/><integer name=\"seed\" value=\"{}\"/></sampler>\
                 <film type=\"hdrfilm\"><integer name=\"width\" value=\"{RES}\"/><integer name=\"height\" value=\"{RES}\"/><rfilter type=\"box\"/></film></sensor>",
                xml_v(cam), xml_v(target), xml_v(up), c.seed
            );
            let bsdf = format!(
                "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{ALBEDO}, {ALBEDO}, {ALBEDO}\"/></bsdf>"
            );
            let bsdf = if c.twosided {
                format!("<bsdf type=\"twosided\">{bsdf}</bsdf>")
            } else {
                bsdf
            };
            let to_world = format!(
                "<transform name=\"to_world\"><scale value=\"{}\"/><rotate x=\"{}\" y=\"{}\" z=\"{}\" angle=\"{}\"/><translate x=\"{}\" y=\"{}\" z=\"{}\"/></transform>",
                num(c.scale), num(c.axis.x), num(c.axis.y), num(c.axis.z), num(c.angle_deg),
                num(c.offset.x), num(c.offset.y), num(c.offset.z)
            );
            let flip = if c.room {
                "<boolean name=\"flip_normals\" value=\"true\"/>"
            } else {
                ""
            };
            let shape = match c.shape {
                Shape::Quad | Shape::Disk | Shape::Cube if c.by_transform => {
                    let t = match c.shape {
                        Shape::Quad => "rectangle",
                        Shape::Disk => "disk",
                        _ => "cube",
                    };
                    format!("<shape type=\"{t}\">{to_world}{flip}{bsdf}</shape>")
                }
                Shape::Sphere if c.by_transform => {
                    format!("<shape type=\"sphere\">{to_world}{flip}{bsdf}</shape>")
                }
                Shape::Sphere => format!(
                    "<shape type=\"sphere\"><point name=\"center\" value=\"{}\"/><float name=\"radius\" value=\"{}\"/>{flip}{bsdf}</shape>",
                    xml_v(center),
                    num(c.scale)
                ),
                _ => {
                    let ext = if c.seed % 2 == 0 { "obj" } else { "ply" };
                    let file = mesh_file(ext)?;
                    let tw = if c.by_transform { to_world.as_str() } else { "" };
                    // Flat shading, which the analytic answers assume (Mitsuba would give a
                    // mesh without normals smooth ones).
                    format!(
                        "<shape type=\"{ext}\"><string name=\"filename\" value=\"{file}\"/><boolean name=\"face_normals\" value=\"true\"/>{tw}{bsdf}</shape>"
                    )
                }
            };
            x += &shape;
            x.push('\n');
            x += &match c.light {
                Light::Sky => "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter>".to_string(),
                Light::Point => format!(
                    "<emitter type=\"point\"><point name=\"position\" value=\"{}\"/><rgb name=\"intensity\" value=\"1, 1, 1\"/></emitter>",
                    xml_v(light_pos)
                ),
                Light::Directional => format!(
                    "<emitter type=\"directional\"><vector name=\"direction\" value=\"{}\"/><rgb name=\"irradiance\" value=\"1, 1, 1\"/></emitter>",
                    xml_v(-light_dir)
                ),
                Light::AreaSphere => format!(
                    "<shape type=\"sphere\"><point name=\"center\" value=\"{}\"/><float name=\"radius\" value=\"{}\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter></shape>",
                    xml_v(light_pos),
                    num(emitter_radius)
                ),
                Light::AreaQuad => format!(
                    "<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"{}\"/><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform><emitter type=\"area\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter></shape>",
                    num(emitter_radius),
                    xml_v(light_pos),
                    xml_v(center),
                    xml_v(not_parallel(light_dir))
                ),
            };
            x += "\n</scene>\n";
            path = dir.join("scene.xml");
            std::fs::write(&path, x)?;
        }
        _ => {
            let mut t = String::new();
            let _ = writeln!(
                t,
                "[camera]\nposition = {}\ntarget = {}\nup = {}\nfov_y = {fov}\n\
                 [film]\nwidth = {RES}\nheight = {RES}\n\
                 [integrator]\nspp = {SPP}\nmax_depth = {max_depth}\nseed = {}\nsampler = \"independent\"\n\
                 [environment]\nradiance = {env}\n\
                 [materials.m]\nmodel = \"lambert\"\nalbedo = {ALBEDO}\ntwosided = {}\n\
                 [materials.light]\nmodel = \"lambert\"\nalbedo = 0.5",
                vec3(cam),
                vec3(target),
                vec3(up),
                c.seed,
                c.twosided
            );
            let transform = if c.by_transform {
                format!(
                    "transform = {{ rotate = {{ axis = {}, angle_deg = {} }}, scale = {}, translate = {} }}\n",
                    vec3(c.axis),
                    num(c.angle_deg),
                    num(c.scale),
                    vec3(c.offset)
                )
            } else {
                String::new()
            };
            t += "[[shapes]]\nmaterial = \"m\"\n";
            match (c.reader, c.shape) {
                (Reader::Toml, Shape::Sphere) => {
                    let inward = c.room;
                    if c.by_transform {
                        let _ = writeln!(
                            t,
                            "sphere = {{ center = [0.0, 0.0, 0.0], radius = 1.0, inward = {inward} }}"
                        );
                    } else {
                        let _ = writeln!(
                            t,
                            "sphere = {{ center = {}, radius = {}, inward = {inward} }}",
                            vec3(center),
                            num(c.scale)
                        );
                    }
                }
                (Reader::Toml, _) => {
                    let tris: Vec<String> = faces
                        .iter()
                        .map(|f| {
                            format!(
                                "[{}, {}, {}]",
                                vec3(placed[f[0]]),
                                vec3(placed[f[1]]),
                                vec3(placed[f[2]])
                            )
                        })
                        .collect();
                    let _ = writeln!(t, "triangles = [{}]", tris.join(", "));
                }
                (Reader::Obj, _) => {
                    let _ = writeln!(t, "obj = \"{}\"", mesh_file("obj")?);
                }
                _ => {
                    let _ = writeln!(t, "ply = \"{}\"", mesh_file("ply")?);
                }
            }
            t += &transform;
            match c.light {
                Light::Sky => {}
                Light::Point => {
                    let _ = writeln!(
                        t,
                        "[[lights]]\ntype = \"point\"\nposition = {}\nintensity = 1.0",
                        vec3(light_pos)
                    );
                }
                Light::Directional => {
                    let _ = writeln!(
                        t,
                        "[[lights]]\ntype = \"directional\"\ndirection = {}\nirradiance = 1.0",
                        vec3(-light_dir)
                    );
                }
                Light::AreaSphere => {
                    let _ = writeln!(
                        t,
                        "[[shapes]]\nmaterial = \"light\"\nemission = 1.0\nsphere = {{ center = {}, radius = {} }}",
                        vec3(light_pos),
                        num(emitter_radius)
                    );
                }
                Light::AreaQuad => {
                    // Facing the shape's centre.
                    let n = (center - light_pos).normalize();
                    let a = n.cross(not_parallel(n)).normalize() * emitter_radius;
                    let b = n.cross(a);
                    let q = [
                        light_pos - a - b,
                        light_pos - a + b,
                        light_pos + a + b,
                        light_pos + a - b,
                    ];
                    // Counter-clockwise seen from the side n points to.
                    let q = if (q[1] - q[0]).cross(q[2] - q[0]).dot(n) > 0.0 {
                        q
                    } else {
                        [q[0], q[3], q[2], q[1]]
                    };
                    let _ = writeln!(
                        t,
                        "[[shapes]]\nmaterial = \"light\"\nemission = 1.0\nquads = [[{}, {}, {}, {}]]",
                        vec3(q[0]),
                        vec3(q[1]),
                        vec3(q[2]),
                        vec3(q[3])
                    );
                }
            }
            path = dir.join("scene.toml");
            std::fs::write(&path, t)?;
        }
    }
    Ok(path)
}

/// A point inside the room's shape (its own frame): near the centre.
fn random_inside(c: &Case) -> DVec3 {
    let mut r = Rng::new(c.seed as u64 ^ 0x5eed);
    random_dir(&mut r) * (0.4 * r.f64())
}

fn xml_v(v: DVec3) -> String {
    format!("{}, {}, {}", num(v.x), num(v.y), num(v.z))
}

/// What one backend's renders of a case show.
struct Counts {
    /// Samples that lost their light, or shadow rays blocked, where nothing can block.
    false_occlusions: u64,
    /// Pixels that received light they cannot receive (rooms).
    leaks: u64,
    detail: String,
}

fn render(env: &mut Env, s: &Scene, gpu: bool) -> Result<crate::output::RenderOutput> {
    render_on(env, s, gpu)
}

fn counts(
    env: &mut Env,
    c: &Case,
    direct: &Scene,
    camera_only: &Scene,
    gpu: bool,
) -> Result<Counts> {
    let out = render(env, direct, gpu)?;
    if c.room {
        let lit: Vec<f32> = out
            .mean
            .data
            .iter()
            .map(|p| p[0].max(p[1]).max(p[2]))
            .filter(|&v| v != 0.0)
            .collect();
        let worst = lit.iter().copied().fold(0.0f32, f32::max);
        return Ok(Counts {
            false_occlusions: 0,
            leaks: lit.len() as u64,
            detail: format!("{} lit pixels (brightest {worst:e})", lit.len()),
        });
    }
    if c.light != Light::Sky {
        return Ok(Counts {
            false_occlusions: out.shadow_rays_occluded,
            leaks: 0,
            detail: format!(
                "{} of {} shadow rays blocked",
                out.shadow_rays_occluded, out.shadow_rays
            ),
        });
    }
    // Sky: per pixel, the samples that hit the shape (1 - the sky seen directly, from the
    // camera-only render of the same camera rays) against the light they brought back.
    let seen = render(env, camera_only, gpu)?;
    let spp = out.spp as f64;
    let (mut lost, mut pixels) = (0.0f64, 0u64);
    for (a, b) in out.mean.data.iter().zip(&seen.mean.data) {
        let (v2, v1) = (a[0] as f64, b[0] as f64);
        let hits = (1.0 - v1) * spp;
        let lit = (v2 - v1) * spp / ALBEDO;
        let missing = hits - lit;
        if missing > 0.5 {
            lost += missing;
            pixels += 1;
        }
    }
    Ok(Counts {
        false_occlusions: lost.round() as u64,
        leaks: 0,
        detail: format!(
            "{} samples lost their sky light in {pixels} pixels",
            lost.round()
        ),
    })
}

pub(super) fn case_self_shadow(env: &mut Env, seed: u64) -> Result<CaseResult> {
    let mut r = Rng::new(seed);
    let c = Case::draw(&mut r, seed);
    let dir = tempfile::tempdir()?;
    let load = |depth: u32| -> Result<Scene> {
        let sub = dir.path().join(format!("d{depth}"));
        std::fs::create_dir_all(&sub)?;
        let path = write_scene(&c, &sub, depth)?;
        crate::scene::load(&path)
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| format!("the case's scene was refused ({})", c.describe()))
    };
    let direct = match load(2) {
        Ok(s) => s,
        Err(e) => return Ok(CaseResult::fail(1.0, format!("{e:#}"))),
    };
    let camera_only = load(1)?;
    let mut worst = 0.0f64;
    let mut failures = Vec::new();
    for gpu in [false, true] {
        let k = counts(env, &c, &direct, &camera_only, gpu)?;
        worst = worst.max((k.false_occlusions + k.leaks) as f64);
        if k.false_occlusions > 0 || k.leaks > 0 {
            failures.push(format!("{}: {}", backend_name(gpu), k.detail));
        }
    }
    if failures.is_empty() {
        Ok(CaseResult::ok(worst))
    } else {
        Ok(CaseResult::fail(
            worst,
            format!("{}: {}", c.describe(), failures.join("; ")),
        ))
    }
}
