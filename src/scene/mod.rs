//! The in-memory scene both renderers consume.
//!
//! A scene file (`scenes/*.toml`, format documented in `scenes/README.md`) is parsed by
//! [`load`] into a [`Scene`]: flat lists of triangles and spheres, each tagged with a material
//! index and an optional emitter index. The BVH (`crate::bvh`) is built over these lists and the
//! GPU upload (`crate::gpu::scene_buffers`) packs them without further interpretation.
//!
//! The loader's files depend on each other as a tree: `load` (the entry points) uses `schema`
//! (the raw serde form), `spanned` (values with their lines) and `assemble` (checks and
//! flattening); `assemble` uses `obj` (OBJ meshes) and `ply_shape`
//! (PLY meshes, read by `ply`); both use `geometry` (the shape transform and
//! the triangle checks); every step reports an `error::SceneError`. A file that is not TOML is
//! named by `sniff` ("this looks like a pbrt scene"). `environment` checks `[environment]` (a
//! constant or an environment map), `textures` a material's texture tables, both reading their
//! images through `images`.

mod assemble;
mod delta_lights;
mod environment;
mod error;
mod geometry;
mod images;
pub mod load;
pub mod mitsuba;
mod mtl;
mod obj;
mod obj_plain;
pub mod ply;
mod ply_shape;
mod schema;
pub mod shapes;
pub mod sniff;
mod spanned;
mod textures;
mod transform;

use crate::brdf::Material;
use glam::{Vec2, Vec3};

/// The camera: a pinhole, or a thin lens when `aperture_radius` > 0. `fov_y_deg` is the full
/// vertical field of view.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov_y_deg: f32,
    /// The lens's radius; 0 for a pinhole (`crate::camera`).
    pub aperture_radius: f32,
    /// The distance, along the view direction, of the plane in focus (thin lens only).
    pub focus_distance: f32,
    /// The image mirrored left to right: x runs to the camera's left (a Mitsuba camera whose
    /// `to_world` mirrors).
    pub mirror: bool,
}

/// Integrator settings; the command line may override them.
#[derive(Clone, Debug, PartialEq)]
pub struct Integrator {
    pub spp: u32,
    /// Maximum number of path segments; the camera-to-first-hit segment is one.
    pub max_depth: u32,
    pub seed: u32,
    /// Russian roulette from `rr_start_depth` on (off by default: unbiased but noisier).
    pub russian_roulette: bool,
    pub rr_start_depth: u32,
    /// Camera rays pass through the emitters they meet and do not see the environment (the
    /// light of both still reaches the scene): Mitsuba's `hide_emitters`.
    pub hide_emitters: bool,
    /// Where the random numbers come from ([`crate::rng::Sampler`]).
    pub sampler: crate::rng::Sampler,
    /// When only a range of a render's samples is rendered (`--samples`, a part of a split
    /// render), the samples per pixel of the whole render: it sizes the `multijitter` pattern,
    /// so that the parts draw the points of the whole and merge into it exactly. None: `spp`.
    pub pattern_spp: Option<u32>,
    /// When the render is in independent batches (`render --batches K`), the samples per pixel
    /// of one batch (a power of two): each batch is its own `multijitter` pattern or `sobol`
    /// scramble ([`crate::rng::pattern_bits`]). None: no batches.
    pub batch_spp: Option<u32>,
}

impl Integrator {
    /// The samples per pixel that size the sampler's patterns ([`crate::rng::multijitter_bits`]).
    pub fn pattern_spp(&self) -> u32 {
        self.pattern_spp.unwrap_or(self.spp)
    }

    /// The bits of the sampler's patterns, as both backends take them
    /// ([`crate::rng::pattern_bits`]).
    pub fn pattern_bits(&self) -> u32 {
        crate::rng::pattern_bits(self.sampler, self.pattern_spp(), self.batch_spp)
    }
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator {
            spp: 16,
            max_depth: 8,
            seed: 0,
            russian_roulette: false,
            rr_start_depth: 3,
            hide_emitters: false,
            sampler: crate::rng::Sampler::default(),
            pattern_spp: None,
            batch_spp: None,
        }
    }
}

/// A one-sided emitter: radiance leaves the front side (the side the geometric normal points to).
#[derive(Clone, Debug, PartialEq)]
pub struct Emitter {
    pub radiance: Vec3,
}

/// A light without area (`[[lights]]` in `scenes/README.md`): no ray can hit it, so it is
/// reached only by next-event estimation (never weighted against BSDF sampling).
#[derive(Clone, Debug, PartialEq)]
pub enum DeltaLight {
    /// Radiant intensity `intensity` (per steradian, the same in every direction) from
    /// `position`: irradiance `intensity · cos θ / r²` at distance r.
    Point { position: Vec3, intensity: Vec3 },
    /// Irradiance `irradiance` on a surface facing the light, arriving from infinitely far
    /// along the unit `direction` (the way the light travels, as in Mitsuba).
    Directional { direction: Vec3, irradiance: Vec3 },
}

/// One triangle. Positions are in world space; the geometric normal is
/// `normalize(cross(v1 - v0, v2 - v0))` and defines the front side. Its optional per-vertex
/// attributes are kept apart, in [`Scene::attributes`], so that a big mesh without them (the
/// usual case) takes 48 bytes a triangle instead of 116 (docs/bench-log.md: set-up memory).
#[derive(Clone, Debug, PartialEq)]
pub struct Triangle {
    pub v: [Vec3; 3],
    pub material: u32,
    pub emitter: Option<u32>,
}

/// The per-vertex attributes of one triangle, each optional.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VertexAttributes {
    /// Per-vertex shading normals, if the mesh has them (else the geometric normal is used).
    pub n: Option<[Vec3; 3]>,
    /// Per-vertex texture coordinates, if the mesh has them (used for the tangent dp/du).
    pub uv: Option<[Vec2; 3]>,
}

impl VertexAttributes {
    /// No normals and no texture coordinates.
    pub const NONE: VertexAttributes = VertexAttributes { n: None, uv: None };
}

/// An analytic sphere. The front side is the outside, unless `inward` is set (a closed room
/// seen from within).
#[derive(Clone, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub material: u32,
    pub emitter: Option<u32>,
    pub inward: bool,
    /// How the sphere's transform turned it, for its texture coordinates (`crate::texture`),
    /// which turn with it as Mitsuba's do; `None` when it was not turned.
    pub frame: Option<SphereFrame>,
}

/// A turned sphere's own axes: [`SphereFrame::to_local`] takes a direction from its centre
/// into the frame in which its texture coordinates are laid out (the frame before the
/// transform). The turn is a unit quaternion `q` (x, y, z, w), followed by z → −z when the
/// transform mirrors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereFrame {
    pub q: [f32; 4],
    pub mirror: bool,
}

impl SphereFrame {
    /// `d` in the sphere's own frame: `d + w·t + q⃗ × t` with `t = 2·q⃗ × d` (the rotation by
    /// the unit quaternion), then z negated for a mirror. GLSL twin: `sphere_local`
    /// (texture.glsl), the same operations in the same order.
    pub fn to_local(&self, d: Vec3) -> Vec3 {
        let [x, y, z, w] = self.q;
        let v = Vec3::new(x, y, z);
        let t = v.cross(d) * 2.0;
        let r = d + t * w + v.cross(t);
        if self.mirror {
            Vec3::new(r.x, r.y, -r.z)
        } else {
            r
        }
    }
}

#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene came from (for messages).
    pub path: std::path::PathBuf,
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub integrator: Integrator,
    pub materials: Vec<Material>,
    /// Material names, parallel to `materials`.
    pub material_names: Vec<String>,
    /// Each material's parameters as the scene file gave them (`model` included), parallel to
    /// `materials` (for a material of an OBJ's MTL library, the parameters it was made with):
    /// what `brdfwave convert` writes for the models Mitsuba lacks.
    pub material_params: Vec<std::collections::BTreeMap<String, toml::Value>>,
    pub emitters: Vec<Emitter>,
    pub triangles: Vec<Triangle>,
    /// The vertex attributes of `triangles`, index for index, up to the last triangle that has
    /// any: shorter than `triangles` (empty for a scene without them), the triangles past its
    /// end have none. Read it through [`Scene::attributes_of`].
    pub attributes: Vec<VertexAttributes>,
    pub spheres: Vec<Sphere>,
    /// Point and directional lights.
    pub lights: Vec<DeltaLight>,
    /// Constant environment radiance seen by rays that leave the scene.
    pub environment: Vec3,
    /// The environment map, when the scene has one (then `environment` is zero): radiance by
    /// direction, sampled for next-event estimation ([`crate::envmap`]).
    pub environment_map: Option<std::sync::Arc<crate::envmap::EnvMap>>,
    /// Legal but suspicious content found while loading (unused materials, skipped
    /// zero-area OBJ triangles, ignored MTL files, …), each `warning: file:line: …`.
    pub warnings: Vec<String>,
}

impl Scene {
    /// The vertex attributes of triangle `i` (none past the end of [`Scene::attributes`]).
    pub fn attributes_of(&self, i: usize) -> VertexAttributes {
        self.attributes
            .get(i)
            .copied()
            .unwrap_or(VertexAttributes::NONE)
    }

    /// Whether some triangle has shading normals.
    pub fn has_shading_normals(&self) -> bool {
        self.attributes.iter().any(|a| a.n.is_some())
    }

    /// Whether some triangle has texture coordinates.
    pub fn has_uvs(&self) -> bool {
        self.attributes.iter().any(|a| a.uv.is_some())
    }

    /// The models (indices into `brdf::MODELS`, ascending) of the materials that scatter: the
    /// models that get a queue and a `shade_<model>` stage, on both backends.
    pub fn shaded_models(&self) -> Vec<usize> {
        let used: std::collections::BTreeSet<usize> = self
            .materials
            .iter()
            .filter(|m| m.brdf.scatters())
            .map(|m| m.model)
            .collect();
        used.into_iter().collect()
    }
}

impl Triangle {
    pub fn geometric_normal_unnormalized(&self) -> Vec3 {
        (self.v[1] - self.v[0]).cross(self.v[2] - self.v[0])
    }
    /// The unit geometric normal, overflow-safe (`robust::triangle_normal`).
    pub fn geometric_normal(&self) -> Vec3 {
        crate::robust::triangle_normal(&self.v)
    }
    /// The area in f64: finite for every triangle with finite f32 vertices.
    pub fn area(&self) -> f64 {
        0.5 * crate::robust::triangle_double_area_f64(&self.v)
    }
}

pub use error::SceneError;
pub use load::{load, load_read, load_str, load_with};
