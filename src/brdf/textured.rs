//! Textured parameters: a material whose parameters vary over the surface (`kd = { texture =
//! "wood.png" }`, `scenes/README.md`). The textures themselves (files, filtering, wrapping) are
//! `crate::texture`; this file is how a model takes their values.
//!
//! **CPU.** At a shading point the renderer looks up each textured parameter and asks the
//! model for the material with those values ([`super::Brdf::with_params`]): each model builds
//! itself as its parser would (derived quantities such as Ward's lobe-selection probability
//! recomputed), so a textured material is exactly the constant material of the values at that
//! point.
//!
//! **GPU.** The same in two steps, since the record is what the shaders read: the values are
//! written into the material record where the model's `pack` puts the parameter (its
//! [`RecordSlot`], declared beside the parameter with `.at(word)` or `.angle_at(word)`), then the
//! model's GLSL function `<model>_textured(inout Material m)` recomputes what `pack` derives
//! from them (Phong's and Ward's lobe-selection probability, Blinn–Phong's normalisation);
//! `shaders/texture.glsl` does the first step, `BRDF_TEXTURED` names the second.

use super::params::{Kind, Param};
use glam::Vec3;

/// How a value is written into the GPU record at its word (`shaders/texture.glsl`,
/// `texture_write`). The codes are the GLSL `TEXTURE_SLOT_*` numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotMode {
    /// An RGB value into three words.
    Rgb = 0,
    /// A scalar into one word.
    Scalar = 1,
    /// A scalar into three words (Cook–Torrance's dielectric ior in the Fresnel slot).
    Splat = 2,
    /// An angle in degrees as (cos, sin) into two words (a rotation).
    Angle = 3,
}

/// Where a parameter's value goes in the GPU record: the word of `p[]` (0 = `p[0].x`) and how.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecordSlot {
    pub word: u32,
    pub mode: SlotMode,
}

impl RecordSlot {
    /// The slot of `p` at `word`: three words for a colour, one for a scalar.
    pub const fn of(p: &Param, word: u32) -> RecordSlot {
        let mode = match p.kind {
            Kind::Rgb(_) => SlotMode::Rgb,
            _ => SlotMode::Scalar,
        };
        RecordSlot { word, mode }
    }
}

/// The values of a material's textured parameters at one point: RGB for a colour parameter,
/// the value in every channel for a scalar one.
#[derive(Clone, Debug, Default)]
pub struct ParamValues {
    pub values: Vec<(&'static str, Vec3)>,
}

impl ParamValues {
    /// The value of colour parameter `p`, or `constant` when it has no texture.
    pub fn rgb(&self, p: &Param, constant: Vec3) -> Vec3 {
        self.get(p).unwrap_or(constant)
    }
    /// The value of scalar parameter `p`, or `constant` when it has no texture.
    pub fn scalar(&self, p: &Param, constant: f32) -> f32 {
        self.get(p).map_or(constant, |v| v.x)
    }
    /// Whether `p` has a texture.
    pub fn has(&self, p: &Param) -> bool {
        self.get(p).is_some()
    }
    fn get(&self, p: &Param) -> Option<Vec3> {
        self.values
            .iter()
            .find(|(n, _)| *n == p.name)
            .map(|(_, v)| *v)
    }
}
