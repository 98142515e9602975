//! The raw (serde) form of a scene file: one struct per table of the format
//! (`scenes/README.md`), every table `deny_unknown_fields`, every value that a message may
//! point at wrapped in [`Sp`] so that its line is known. No value is checked here; that is
//! [`super::assemble`]'s job.

use super::spanned::Sp;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;

pub(super) type V3 = Sp<Arr<f64, 3>>;
pub(super) type Quads = Vec<Sp<Arr<Arr<f64, 3>, 4>>>;
pub(super) type Tris = Vec<Sp<Arr<Arr<f64, 3>, 3>>>;
/// A material's fields, given to [`brdf::parse_material`].
pub(super) type MaterialTable = BTreeMap<String, Sp<toml::Value>>;

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a scene: tables [camera], [film], [materials.NAME], [[shapes]] and optional ones"
)]
pub(super) struct RawScene {
    pub(super) camera: RawCamera,
    pub(super) film: RawFilm,
    pub(super) integrator: Option<RawIntegrator>,
    pub(super) environment: Option<RawEnvironment>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, Sp<MaterialTable>>,
    #[serde(default)]
    pub(super) shapes: Vec<Sp<RawShape>>,
    #[serde(default)]
    pub(super) lights: Vec<Sp<RawLight>>,
}

/// A `[[lights]]` table: a point or directional light ([`super::delta_lights`] checks which
/// fields its type takes).
#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a light table (type = point or directional, and its fields)"
)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    pub(super) kind: Sp<String>,
    pub(super) position: Option<V3>,
    pub(super) intensity: Option<Sp<Triple>>,
    pub(super) direction: Option<V3>,
    pub(super) irradiance: Option<Sp<Triple>>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a [camera] table (position, target, fov_y, ...)"
)]
pub(super) struct RawCamera {
    pub(super) position: V3,
    pub(super) target: V3,
    pub(super) up: Option<V3>,
    pub(super) fov_y: Sp<f64>,
    /// The thin lens's radius (0 or absent: a pinhole).
    pub(super) aperture_radius: Option<Sp<f64>>,
    /// The distance of the plane in focus (default: the target's distance).
    pub(super) focus_distance: Option<Sp<f64>>,
    /// The image mirrored left to right (default false).
    #[serde(default)]
    pub(super) mirror: Option<Sp<bool>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "a [film] table (width, height)")]
pub(super) struct RawFilm {
    pub(super) width: Sp<u32>,
    pub(super) height: Sp<u32>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "an [integrator] table (spp, max_depth, ...)"
)]
pub(super) struct RawIntegrator {
    pub(super) spp: Option<Sp<u32>>,
    pub(super) max_depth: Option<Sp<u32>>,
    pub(super) seed: Option<u32>,
    pub(super) russian_roulette: Option<bool>,
    pub(super) rr_start_depth: Option<Sp<u32>>,
    pub(super) sampler: Option<Sp<String>>,
    pub(super) hide_emitters: Option<bool>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "an [environment] table (radiance, or map and its fields)"
)]
pub(super) struct RawEnvironment {
    pub(super) radiance: Option<Sp<Triple>>,
    /// An equirectangular image of the environment ([`super::environment`]).
    pub(super) map: Option<Sp<String>>,
    /// The factor the map's values are multiplied by.
    pub(super) scale: Option<Sp<f64>>,
    /// The map's rotation, in the form of a shape's `transform`.
    pub(super) transform: Option<Sp<RawTransform>>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a shape table (material, and one of sphere, quads, triangles, obj, ply)"
)]
pub(super) struct RawShape {
    pub(super) name: Option<String>,
    pub(super) material: Sp<String>,
    pub(super) emission: Option<Sp<Triple>>,
    pub(super) quads: Option<Sp<Quads>>,
    pub(super) triangles: Option<Sp<Tris>>,
    pub(super) sphere: Option<Sp<RawSphere>>,
    pub(super) obj: Option<Sp<String>>,
    pub(super) ply: Option<Sp<String>>,
    /// Use the OBJ file's MTL materials (only with `obj`).
    pub(super) mtl: Option<Sp<bool>>,
    /// Ignore the mesh file's vertex normals and shade with the geometric normal (only with
    /// `obj` or `ply`; Mitsuba's `face_normals`).
    pub(super) face_normals: Option<Sp<bool>>,
    pub(super) transform: Option<Sp<RawTransform>>,
    /// Set by the Mitsuba reader for an OBJ without `to_world`: its vertices are world space
    /// as written, taken bit for bit ([`super::geometry::Transform::AsWritten`]).
    #[serde(skip)]
    pub(super) as_written: bool,
    /// Set by the Mitsuba reader for `obj` and `ply` shapes, which then follow Mitsuba's
    /// rules: a mesh without vertex normals (and without `face_normals`) is shaded with smooth
    /// ones ([`super::geometry::vertex_normals`]), and an OBJ file's MTL materials are not read.
    #[serde(skip)]
    pub(super) mitsuba_mesh: bool,
    /// Which side of the shape's surfaces is the front (set by the Mitsuba reader; TOML scenes
    /// keep the default, the winding).
    #[serde(skip)]
    pub(super) sides: Sides,
    /// The texture coordinates of `triangles`, per vertex (the Mitsuba reader's `rectangle`,
    /// `cube` and `disk`, parameterised as Mitsuba parameterises them).
    #[serde(skip)]
    pub(super) triangle_uvs: Option<Vec<[[f32; 2]; 3]>>,
    /// The mesh (`obj`, `ply`) turned over, winding and vertex normals (the Mitsuba reader's
    /// `flip_normals`).
    #[serde(skip)]
    pub(super) flip_mesh: bool,
}

/// Which side of a shape's triangles is the front.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum Sides {
    /// The counter-clockwise winding, as placed: a mirroring transform turns the shape over
    /// (TOML scenes: `scenes/README.md`).
    #[default]
    Winding,
    /// The reader has wound the shape's triangles (and set a sphere's `inward`) so that they
    /// face as Mitsuba's normals do, mirrored or not: Mitsuba's `rectangle`, `cube`, `disk` and
    /// `sphere`, whose normals go through the inverse transpose of `to_world`.
    Kept,
    /// A mesh triangle with vertex normals faces the side they point to (its winding is turned
    /// to agree), one without by its winding: Mitsuba shades by the interpolated normals.
    ByNormals,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a sphere table ({ center = [x, y, z], radius = r })"
)]
pub(super) struct RawSphere {
    pub(super) center: V3,
    pub(super) radius: Sp<f64>,
    #[serde(default)]
    pub(super) inward: bool,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a transform table (translate, rotate, scale, matrix)"
)]
pub(super) struct RawTransform {
    pub(super) translate: Option<V3>,
    pub(super) scale: Option<Sp<Triple>>,
    pub(super) rotate_y_deg: Option<Sp<f64>>,
    pub(super) rotate: Option<Sp<RawRotate>>,
    /// A row-major 4×4 affine matrix; alone, without the other fields.
    pub(super) matrix: Option<Sp<Arr<Arr<f64, 4>, 4>>>,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "a rotation table ({ axis = [x, y, z], angle_deg = degrees })"
)]
pub(super) struct RawRotate {
    pub(super) axis: V3,
    pub(super) angle_deg: Sp<f64>,
}

/// A number (meaning the same value three times) or an array of three numbers.
pub(super) struct Triple(pub(super) [f64; 3]);

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

/// An array of exactly `N` values. serde's `[T; N]` reads its first `N` elements and, from
/// TOML, ignores the rest: `position = [0.0, 1.0, -5.0, "junk"]` or a quad with a fifth vertex
/// loaded without a word.
pub(super) struct Arr<T, const N: usize>(pub(super) [T; N]);

impl<T, const N: usize> std::ops::Deref for Arr<T, N> {
    type Target = [T; N];
    fn deref(&self) -> &[T; N] {
        &self.0
    }
}

impl<'de, T: Deserialize<'de>, const N: usize> Deserialize<'de> for Arr<T, N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T, const N: usize>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for V<T, N> {
            type Value = Arr<T, N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of {N} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Arr<T, N>, A::Error> {
                let mut v = Vec::with_capacity(N);
                while v.len() < N {
                    match seq.next_element::<T>()? {
                        Some(x) => v.push(x),
                        None => return Err(de::Error::invalid_length(v.len(), &self)),
                    }
                }
                let mut n = N;
                while seq.next_element::<de::IgnoredAny>()?.is_some() {
                    n += 1;
                }
                if n != N {
                    return Err(de::Error::invalid_length(n, &self));
                }
                match v.try_into() {
                    Ok(a) => Ok(Arr(a)),
                    Err(_) => Err(de::Error::invalid_length(N, &self)),
                }
            }
        }
        d.deserialize_seq(V(std::marker::PhantomData))
    }
}
