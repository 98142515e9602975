//! Image textures on material parameters (`kd = { texture = "wood.png" }`, `scenes/README.md`):
//! the image as a parameter reads it, its lookup, and the (u, v) of a surface point. GLSL twin
//! (independent code, the same conventions and arithmetic): `shaders/texture.glsl`. How a model
//! takes the values is `crate::brdf::textured`.
//!
//! **Values.** Read once, when the scene loads, into what the parameter means: a PNG (8 or 16
//! bits) has its sRGB curve decoded unless `raw`, which is `false` by default on a colour
//! parameter and `true` on a scalar one (a PNG's codes c/255 as stored: a roughness map's
//! numbers); EXR, HDR and PFM are linear. A scalar parameter reduces a colour image to its
//! luminance (Rec. 709), as Mitsuba 3's `eval_1` does (Mitsuba decodes unless `raw` on both
//! kinds: its reader sets `raw` as Mitsuba's default). Every value is then clamped into the parameter's range (a NaN to its lower
//! end), and the clamped texels are counted in one warning per texture.
//!
//! **Lookup** (Mitsuba 3's `bitmap` conventions, so that its scenes render alike): (u, v) is first
//! mapped by the texture's `to_uv` (a 2-D affine map); texel (x, y) sits at ((x + ½)/W, (y + ½)/H),
//! row 0 the image's top row at v = 0. `bilinear` (the default) weighs the four nearest texels,
//! `nearest` takes the texel that holds the point; outside [0, 1) the texel index wraps by
//! `repeat` (the default), `mirror` (…, 1, 0, 0, 1, …) or `clamp`. The arithmetic is basic f32
//! operations in a fixed order on both sides, so both renderers read the same values.
//!
//! **(u, v) of a surface** (also Mitsuba's): a triangle interpolates its vertices' texture
//! coordinates, or takes (b1, b2), its barycentric weights, when it has none; a `quads` shape
//! whose material has a texture gets (0, 0), (1, 0), (1, 1), (0, 1) at v0 … v3 (Mitsuba's
//! `rectangle`); an OBJ file's `vt` v is flipped (OBJ's v runs up the image), a PLY file's is
//! taken as stored; a sphere has u = φ/2π with φ = atan2(y, x) and v = θ/π with θ from +z, in
//! the sphere's own frame: the world's axes about its centre, turned (or mirrored) as its
//! transform turned the sphere ([`crate::scene::SphereFrame`]), as Mitsuba's `to_world` turns
//! its sphere's.

use crate::brdf::params::Param;
use crate::brdf::textured::RecordSlot;
use glam::{Vec2, Vec3};
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// How many texels [`Texture::for_param`] clamped into the parameter's range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Clamped {
    /// Texels with any channel changed.
    pub texels: u64,
    /// Of those, texels with a NaN channel.
    pub nan: u64,
}

/// How a lookup between texels is filtered (`filter`, Mitsuba's `filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Filter {
    Bilinear = 0,
    Nearest = 1,
}

/// What a texel index outside the image becomes (`wrap`, Mitsuba's `wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wrap {
    Repeat = 0,
    Mirror = 1,
    Clamp = 2,
}

impl Filter {
    pub const NAMES: [&'static str; 2] = ["bilinear", "nearest"];
    pub fn parse(s: &str) -> Option<Filter> {
        [Filter::Bilinear, Filter::Nearest]
            .into_iter()
            .find(|f| f.name() == s)
    }
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

impl Wrap {
    pub const NAMES: [&'static str; 3] = ["repeat", "mirror", "clamp"];
    pub fn parse(s: &str) -> Option<Wrap> {
        [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp]
            .into_iter()
            .find(|w| w.name() == s)
    }
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

/// A texture as one parameter reads it.
#[derive(Clone)]
pub struct Texture {
    /// The image file.
    pub path: PathBuf,
    /// `raw`: a PNG's codes taken as they are (no sRGB decoding).
    pub raw: bool,
    pub width: u32,
    pub height: u32,
    /// The values, linear and within the parameter's range, row 0 at the top.
    pub texels: Vec<[f32; 3]>,
    pub filter: Filter,
    pub wrap: Wrap,
    /// `to_uv`: (u, v) ↦ (m[0]·(u, v, 1), m[1]·(u, v, 1)).
    pub to_uv: [[f32; 3]; 2],
}

impl fmt::Debug for Texture {
    /// The texels as a hash of their bits (the scene hash prints materials with `{:?}`).
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "Texture {{ {}x{}, {:?}, {:?}, to_uv {:?}, texels {:016x} }}",
            self.width,
            self.height,
            self.filter,
            self.wrap,
            self.to_uv,
            crate::hash::texels_hash(&self.texels)
        )
    }
}

/// A field of a texture table (`kd = { texture = "wood.png", … }`): the parser takes exactly
/// these, and scenes/README.md's table of them is generated from here (`brdf::docs`).
pub struct TableField {
    pub name: &'static str,
    pub kind: &'static str,
    pub default: &'static str,
    pub meaning: &'static str,
}

/// The fields of a texture table.
pub const TABLE_FIELDS: &[TableField] = &[
    TableField {
        name: "texture",
        kind: "string, path",
        default: "required",
        meaning: "the image: `.exr`, `.hdr` (Radiance RGBE), `.pfm` or `.png` (8 or 16 bits), relative to the scene file's directory",
    },
    TableField {
        name: "raw",
        kind: "boolean",
        default: "`false` on a colour parameter, `true` on a number",
        meaning: "take a PNG's values as stored instead of decoding the sRGB curve",
    },
    TableField {
        name: "filter",
        kind: "string",
        default: "`\"bilinear\"`",
        meaning: "`bilinear` (the four nearest texels) or `nearest` (the texel that holds the point)",
    },
    TableField {
        name: "wrap",
        kind: "string",
        default: "`\"repeat\"`",
        meaning: "texel indices outside the image: `repeat`, `mirror` or `clamp`",
    },
    TableField {
        name: "to_uv",
        kind: "table",
        default: "identity",
        meaning: "a 2-D map of the surface's (u, v) before the lookup: `{ scale = s or [su, sv], translate = [tu, tv] }` (scale first) or `{ matrix = [[a, b, c], [d, e, f]] }`",
    },
];

/// The identity `to_uv`.
pub const IDENTITY_UV: [[f32; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// A parameter of a material with its texture (`crate::brdf::Material::textures`).
#[derive(Clone, Debug)]
pub struct ParamTexture {
    pub param: &'static Param,
    pub texture: Arc<Texture>,
    /// Where the value goes in the material's GPU record; `None` when the record does not hold
    /// the parameter (then no shader reads it).
    pub slot: Option<RecordSlot>,
}

impl Texture {
    /// The texture of `pixels` (`width` × `height`, row 0 at the top, as stored) for parameter
    /// `param`: decoded when `srgb` (a PNG's codes) and not `raw`, reduced to luminance for a
    /// scalar parameter, clamped into the parameter's range. Returns it and how many texels
    /// were clamped (a texel with a NaN to the range's low end).
    #[allow(clippy::too_many_arguments)]
    pub fn for_param(
        path: PathBuf,
        raw: bool,
        (width, height, pixels): (u32, u32, &[[f32; 3]]),
        srgb: bool,
        param: &Param,
        filter: Filter,
        wrap: Wrap,
        to_uv: [[f32; 3]; 2],
    ) -> (Texture, Clamped) {
        let colour = matches!(param.kind, crate::brdf::Kind::Rgb(_));
        let (lo, hi) = param.texture_range();
        let mut counts = Clamped::default();
        let texels = pixels
            .iter()
            .map(|p| {
                let decoded = match srgb && !raw {
                    true => p.map(crate::imageio::srgb_to_linear),
                    false => *p,
                };
                let values = match colour {
                    true => decoded,
                    false => [crate::lights::luminance(Vec3::from_array(decoded)); 3],
                };
                let nan = values.iter().any(|x| x.is_nan());
                let out = values.map(|x| if x.is_nan() { lo } else { x.clamp(lo, hi) });
                counts.texels += u64::from(nan || out != values);
                counts.nan += u64::from(nan);
                out
            })
            .collect();
        (
            Texture {
                path,
                raw,
                width,
                height,
                texels,
                filter,
                wrap,
                to_uv,
            },
            counts,
        )
    }

    fn texel(&self, x: i32, y: i32) -> Vec3 {
        let x = wrap_index(x, self.width, self.wrap);
        let y = wrap_index(y, self.height, self.wrap);
        Vec3::from_array(self.texels[(y * self.width + x) as usize])
    }

    /// The value at surface coordinates `uv` (module docs).
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let m = &self.to_uv;
        let u = m[0][0] * uv.x + m[0][1] * uv.y + m[0][2];
        let v = m[1][0] * uv.x + m[1][1] * uv.y + m[1][2];
        let (w, h) = (self.width as f32, self.height as f32);
        match self.filter {
            Filter::Nearest => self.texel(index_of(u * w), index_of(v * h)),
            Filter::Bilinear => {
                let (s, t) = (coord(u * w - 0.5), coord(v * h - 0.5));
                let (fs, ft) = (s.floor(), t.floor());
                let (x0, y0) = (fs as i32, ft as i32);
                let (ax, ay) = (s - fs, t - ft);
                let a = self.texel(x0, y0) * (1.0 - ax) + self.texel(x0 + 1, y0) * ax;
                let b = self.texel(x0, y0 + 1) * (1.0 - ax) + self.texel(x0 + 1, y0 + 1) * ax;
                a * (1.0 - ay) + b * ay
            }
        }
    }
}

/// The largest texel coordinate a lookup takes, 2^28: far outside any image (16384 texels a
/// side at most), and small enough that the GLSL twin's unsigned modulo cannot overflow.
const MAX_COORD: f32 = 268_435_456.0;

/// A texel coordinate within ±[`MAX_COORD`], 0 for a NaN or an infinity: a texture coordinate
/// of 1e30 or NaN does not overflow the index.
fn coord(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(-MAX_COORD, MAX_COORD)
    } else {
        0.0
    }
}

/// The texel that holds texel coordinate `x`.
fn index_of(x: f32) -> i32 {
    coord(x).floor() as i32
}

/// Texel index `i` of a side of `n` texels under `wrap`.
pub fn wrap_index(i: i32, n: u32, wrap: Wrap) -> u32 {
    let n = n as i32;
    let r = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let p = i.rem_euclid(2 * n);
            if p < n {
                p
            } else {
                2 * n - 1 - p
            }
        }
    };
    r as u32
}

/// (u, v) of a point on a sphere, `d` = (p − centre) / radius (module docs).
pub fn sphere_uv(d: Vec3) -> Vec2 {
    let mut u = crate::envmap::atan2_f32(d.y, d.x) * 0.159_154_94;
    if u < 0.0 {
        u += 1.0;
    }
    let v = crate::envmap::atan2_f32((d.x * d.x + d.y * d.y).sqrt(), d.z) * 0.318_309_87;
    Vec2::new(u, v)
}

/// (u, v) of the surface point `p` of BVH hit `hit` (module docs). CPU only: the GLSL twin is
/// `surface_uv` (texture.glsl).
pub fn hit_uv(scene: &crate::scene::Scene, hit: &crate::bvh::Hit, p: Vec3) -> Vec2 {
    if hit.prim & crate::bvh::SPHERE_BIT != 0 {
        let s = &scene.spheres[(hit.prim & !crate::bvh::SPHERE_BIT) as usize];
        let d = (p - s.center) / s.radius;
        sphere_uv(s.frame.map_or(d, |f| f.to_local(d)))
    } else {
        let a = scene.attributes_of(hit.prim as usize);
        triangle_uv(a.uv, hit.bary.x, hit.bary.y)
    }
}

/// (u, v) of a triangle's point of barycentric weights (b1, b2): its vertices' coordinates
/// interpolated, or (b1, b2) without them.
pub fn triangle_uv(uv: Option<[Vec2; 3]>, b1: f32, b2: f32) -> Vec2 {
    match uv {
        Some([a, b, c]) => a * (1.0 - b1 - b2) + b * b1 + c * b2,
        None => Vec2::new(b1, b2),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::params::Param;

    const P: Param = Param::rgb("kd", "", [0.5; 3], (0.0, 1.0), "");

    fn tex(w: u32, h: u32, filter: Filter, wrap: Wrap) -> Texture {
        let px: Vec<[f32; 3]> = (0..w * h)
            .map(|i| [((i / w) * 10 + i % w) as f32 / 100.0; 3])
            .collect();
        Texture::for_param(
            "t".into(),
            true,
            (w, h, &px),
            false,
            &P,
            filter,
            wrap,
            IDENTITY_UV,
        )
        .0
    }

    /// The values Mitsuba 3.9.1's `bitmap` gives for a 4 × 2 image of 10 y + x (its filters
    /// and wrap modes at the same points; tests/texture.rs has the live comparison).
    #[test]
    fn lookups_follow_mitsubas_bitmap() {
        let at = [
            (0.125, 0.25),
            (0.375, 0.25),
            (0.125, 0.75),
            (0.0, 0.25),
            (0.25, 0.25),
            (0.99, 0.25),
            (1.125, 0.25),
            (-0.125, 0.25),
            (0.125, -0.25),
        ];
        let want = [
            (
                Filter::Bilinear,
                Wrap::Repeat,
                [0.0, 1.0, 10.0, 1.5, 0.5, 1.62, 0.0, 3.0, 10.0],
            ),
            (
                Filter::Bilinear,
                Wrap::Mirror,
                [0.0, 1.0, 10.0, 0.0, 0.5, 3.0, 3.0, 0.0, 0.0],
            ),
            (
                Filter::Bilinear,
                Wrap::Clamp,
                [0.0, 1.0, 10.0, 0.0, 0.5, 3.0, 3.0, 0.0, 0.0],
            ),
            (
                Filter::Nearest,
                Wrap::Repeat,
                [0.0, 1.0, 10.0, 0.0, 1.0, 3.0, 0.0, 3.0, 10.0],
            ),
            (
                Filter::Nearest,
                Wrap::Clamp,
                [0.0, 1.0, 10.0, 0.0, 1.0, 3.0, 3.0, 0.0, 0.0],
            ),
        ];
        for (f, w, values) in want {
            let t = tex(4, 2, f, w);
            for ((u, v), want) in at.iter().zip(values) {
                let got = t.lookup(Vec2::new(*u, *v)).x * 100.0;
                assert!(
                    (got - want).abs() < 1e-3,
                    "{f:?} {w:?} ({u}, {v}): {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn wild_coordinates_stay_in_the_image() {
        let t = tex(3, 2, Filter::Bilinear, Wrap::Mirror);
        for u in [f32::NAN, f32::INFINITY, -1e30, 1e30, -7.3] {
            assert!(t.lookup(Vec2::new(u, 0.5)).is_finite());
        }
        assert_eq!(wrap_index(-1, 3, Wrap::Mirror), 0);
        assert_eq!(wrap_index(3, 3, Wrap::Mirror), 2);
        assert_eq!(wrap_index(-4, 3, Wrap::Repeat), 2);
    }

    #[test]
    fn values_are_decoded_reduced_and_clamped() {
        let px = [[0.5, 0.5, 0.5], [2.0, -1.0, f32::NAN]];
        let (t, n) = Texture::for_param(
            "t".into(),
            false,
            (2, 1, &px),
            true,
            &P,
            Filter::Bilinear,
            Wrap::Repeat,
            IDENTITY_UV,
        );
        assert!((t.texels[0][0] - crate::imageio::srgb_to_linear(0.5)).abs() < 1e-7);
        assert_eq!(t.texels[1], [1.0, 0.0, 0.0]);
        // One texel, however many of its channels, and one of them NaN.
        assert_eq!(n, Clamped { texels: 1, nan: 1 });
        // A scalar parameter: the codes as stored when raw (its default), else decoded; a
        // colour is reduced to its luminance.
        const S: Param = Param::scalar("r", "", 0.2, (0.0, 1.0), "");
        let scalar = |raw: bool, px: &[[f32; 3]]| {
            Texture::for_param(
                "t".into(),
                raw,
                (1, 1, px),
                true,
                &S,
                Filter::Bilinear,
                Wrap::Repeat,
                IDENTITY_UV,
            )
        };
        let (t, n) = scalar(true, &px[..1]);
        assert_eq!(
            (t.texels[0], n),
            ([0.5; 3], Clamped::default()),
            "raw: the codes"
        );
        let (t, _) = scalar(false, &px[..1]);
        assert_eq!(t.texels[0], [crate::imageio::srgb_to_linear(0.5); 3]);
        let (t, _) = scalar(true, &[[0.2, 0.6, 0.1]]);
        let l = crate::lights::luminance(Vec3::new(0.2, 0.6, 0.1));
        assert_eq!(t.texels[0], [l; 3]);
    }

    /// Mitsuba's sphere coordinates: +z is v = 0, +x is u = 0, +y is u = ¼.
    #[test]
    fn sphere_coordinates() {
        assert!((sphere_uv(Vec3::Z).y).abs() < 1e-6);
        assert!((sphere_uv(-Vec3::Z).y - 1.0).abs() < 1e-6);
        assert!((sphere_uv(Vec3::X) - Vec2::new(0.0, 0.5)).length() < 1e-6);
        assert!((sphere_uv(Vec3::Y) - Vec2::new(0.25, 0.5)).length() < 1e-6);
        assert!((sphere_uv(-Vec3::Y) - Vec2::new(0.75, 0.5)).length() < 1e-6);
    }
}
