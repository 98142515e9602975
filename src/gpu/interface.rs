//! The Rust–GLSL interface of the wavefront kernels, generated from one description: the
//! header [`glsl`] (included by `shaders/wavefront/state.glsl` as [`HEADER`]) holds the numbers
//! of [`super::layout`] as `#define`s, the declaration of every binding (from
//! [`Binding::kind`], its format and [`Binding::glsl`]), the `Globals` uniform block and the
//! `Push` constants (from the Rust structs below, declared once with [`glsl_block!`]), and
//! the counter positions as functions (from [`CounterBlock::row`], the formula the host uses
//! too). The shader and the host therefore cannot disagree on a binding, a field's position
//! or a counter's place; kajiya's "resources from description values" is the model
//! (Tomasz Stachowiak, kajiya, 2021).

use super::layout::{self, Binding, BlockIndex, CounterBlock, Kind};
use ash::vk;

/// The generated header's name among the shader sources.
pub const HEADER: &str = "wavefront/interface.glsl";

/// A Rust type that stands for a GLSL one in a [`glsl_block!`] struct (scalar layout: each
/// field 4-byte aligned, so the `#[repr(C)]` struct has the block's layout).
pub trait GlslType {
    const GLSL: &'static str;
}
impl GlslType for u32 {
    const GLSL: &'static str = "uint";
}
impl GlslType for f32 {
    const GLSL: &'static str = "float";
}
impl GlslType for [f32; 3] {
    const GLSL: &'static str = "vec3";
}

/// One field of a [`glsl_block!`] struct.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    pub name: &'static str,
    pub glsl: &'static str,
    pub doc: &'static str,
}

/// Declares a `#[repr(C)]` plain-old-data struct and, from the same lines, its field list
/// (`FIELDS`: name, GLSL type, doc), from which the GLSL block is emitted: a field is declared
/// once, in Rust.
macro_rules! glsl_block {
    ($(#[$meta:meta])* pub struct $name:ident {
        $($(#[doc = $doc:literal])* pub $field:ident: $ty:ty,)*
    }) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $($(#[doc = $doc])* pub $field: $ty,)*
        }

        impl $name {
            /// The fields in order, as the GLSL block declares them.
            pub const FIELDS: &'static [Field] = &[$(Field {
                name: stringify!($field),
                glsl: <$ty as GlslType>::GLSL,
                doc: concat!($($doc),*),
            },)*];
        }
    };
}
pub(crate) use glsl_block;

glsl_block! {
    /// The push constants of every wavefront kernel (GLSL `pc`). A wave traces wave_size =
    /// chunk_pixels × k paths: k consecutive samples of the pixels [chunk_offset, chunk_offset +
    /// chunk_pixels). Small images take several samples per wave, so that a large GPU has enough
    /// paths in flight; large images take one sample of one chunk.
    pub struct Push {
        /// segment index d of the rays being traced / the vertex being shaded
        pub depth: u32,
        /// sample of the wave's first path
        pub sample_index: u32,
        /// first pixel of this chunk
        pub chunk_offset: u32,
        /// paths in this wave
        pub wave_size: u32,
        /// prepare: which arguments to write (PREPARE_*); megakernel: MEGAKERNEL_*
        pub phase: u32,
        /// shade kernels: which material queue
        pub queue_slot: u32,
        /// pixels in this chunk (wave_size is a multiple)
        pub chunk_pixels: u32,
    }
}

glsl_block! {
    /// The scene-wide values (binding `globals`, GLSL `g`, scalar layout).
    pub struct Globals {
        pub cam_origin: [f32; 3],
        pub cam_forward: [f32; 3],
        /// scaled by tan(fov/2)·aspect
        pub cam_right: [f32; 3],
        /// scaled by tan(fov/2)
        pub cam_up: [f32; 3],
        pub environment: [f32; 3],
        pub num_lights: u32,
        pub width: u32,
        pub height: u32,
        pub max_depth: u32,
        pub seed: u32,
        pub rr_enabled: u32,
        pub rr_start_depth: u32,
        /// material queues in use
        pub num_queues: u32,
        /// path slots per wave
        pub wave_paths: u32,
        /// the part of the image rendered (all of it unless TILED): columns tile_x .. tile_x +
        /// tile_width, rows from tile_y
        pub tile_x: u32,
        pub tile_y: u32,
        pub tile_width: u32,
        /// multijitter: the pattern has 2^pattern_bits points; sobol: each batch of
        /// 2^pattern_bits samples has its own scramble, 32 without batches (rng::pattern_bits)
        pub pattern_bits: u32,
        /// SCENE_ENV_MAP: the rows of the world-to-map rotation (src/envmap.rs)
        pub env_x: [f32; 3],
        pub env_y: [f32; 3],
        pub env_z: [f32; 3],
        /// SCENE_ENV_MAP: the map's size in texels
        pub env_width: u32,
        pub env_height: u32,
        /// SCENE_ENV_MAP: the probability that a light sample chooses the map
        pub env_select: f32,
        /// CAMERA_THIN_LENS: the camera's unit right and up vectors times the aperture radius
        pub lens_right: [f32; 3],
        pub lens_up: [f32; 3],
        /// CAMERA_THIN_LENS: the distance of the plane in focus along the view direction
        pub focus_distance: f32,
    }
}

/// `struct { fields } instance;` lines of a block, each field with its doc.
fn block_fields(fields: &[Field]) -> String {
    let mut s = String::new();
    for f in fields {
        s += &format!("    {} {};", f.glsl, f.name);
        if !f.doc.is_empty() {
            s += &format!("  //{}", f.doc);
        }
        s += "\n";
    }
    s
}

/// The GLSL image format qualifier of a texel format, and whether it holds unsigned integers.
fn texel_format(f: vk::Format) -> (&'static str, bool) {
    match f {
        vk::Format::R32_UINT => ("r32ui", true),
        vk::Format::R32G32_UINT => ("rg32ui", true),
        vk::Format::R32G32B32A32_UINT => ("rgba32ui", true),
        vk::Format::R32G32B32A32_SFLOAT => ("rgba32f", false),
        vk::Format::R32_SFLOAT => ("r32f", false),
        other => panic!("no GLSL format for {other:?}: add it to gpu::interface::texel_format"),
    }
}

/// The declaration of binding `b`.
fn declaration(b: Binding) -> String {
    let (name, about) = b.glsl();
    let at = format!("set = 0, binding = BINDING_{}", b.name().to_uppercase());
    let decl = match b.kind() {
        Kind::ReadImage(f) => {
            let (q, uint) = texel_format(f);
            let u = if uint { "u" } else { "" };
            format!("layout({at}, {q}) uniform readonly restrict {u}imageBuffer {name};")
        }
        Kind::Image(f) => {
            let (q, uint) = texel_format(f);
            let u = if uint { "u" } else { "" };
            format!("layout({at}, {q}) uniform restrict {u}imageBuffer {name};")
        }
        Kind::Uniform => {
            assert_eq!(b, Binding::Globals, "the one uniform block is Globals");
            format!(
                "layout(scalar, {at}) uniform Globals {{\n{}}} {name};",
                block_fields(Globals::FIELDS)
            )
        }
        Kind::Storage => {
            let element = b
                .storage_element()
                .unwrap_or_else(|| panic!("storage binding {b:?} has no element type"));
            let block = b.name()[..1].to_uppercase() + &b.name()[1..];
            format!("layout(std430, {at}) buffer {block} {{ {element} {name}[]; }};")
        }
    };
    match b.condition() {
        Some(c) => format!("// {}: {about}\n#ifdef {c}\n{decl}\n#endif\n", b.name()),
        None => format!("// {}: {about}\n{decl}\n", b.name()),
    }
}

/// One binding of a probe kernel's generated interface ([`probe_glsl`]): a binding of the
/// wavefront layout, declared exactly as the wavefront kernels declare it, or a storage buffer of
/// the probe's own.
#[derive(Clone, Copy, Debug)]
pub enum ProbeBinding {
    Layout(Binding),
    /// `layout(std430) <access> buffer <block> { <member>; };` — `member` is the declaration
    /// inside the block, e.g. `"vec4 inputs[]"`.
    Storage {
        block: &'static str,
        member: &'static str,
        access: &'static str,
        about: &'static str,
    },
}

impl ProbeBinding {
    /// The name of its `BINDING_*` define's suffix.
    fn define(self) -> String {
        match self {
            ProbeBinding::Layout(b) => b.name().to_uppercase(),
            ProbeBinding::Storage { block, .. } => block.to_uppercase(),
        }
    }

    pub fn descriptor_type(self) -> vk::DescriptorType {
        match self {
            ProbeBinding::Layout(b) => b.descriptor_type(),
            ProbeBinding::Storage { .. } => vk::DescriptorType::STORAGE_BUFFER,
        }
    }
}

/// The generated interface of a standalone probe kernel (the BRDF probe, the BVH test probe):
/// binding i of `bindings` at slot i with its `BINDING_*` define, then the push constants
/// `pc` from `push` (a [`glsl_block!`] struct's `FIELDS`). A kernel that includes it and then
/// `bvh.glsl` or `brdf/measured.glsl` finds those files' bindings declared (`BVH_DECLARED`,
/// `MEASURED_TABLE_DECLARED`), so no number is written by hand on either side.
pub fn probe_glsl(guard: &str, bindings: &[ProbeBinding], push: &[Field]) -> String {
    let mut s = format!(
        "// A probe kernel's interface, generated by src/gpu/interface.rs `probe_glsl`: edit the\n\
         // description in Rust, not this text.\n#ifndef {guard}\n#define {guard}\n"
    );
    for (i, b) in bindings.iter().enumerate() {
        s += &format!("#define BINDING_{} {i}\n", b.define());
    }
    for b in bindings {
        s += &match *b {
            ProbeBinding::Layout(b) => declaration(b),
            ProbeBinding::Storage {
                block,
                member,
                access,
                about,
            } => format!(
                "// {about}\nlayout(std430, set = 0, binding = BINDING_{}) {access} buffer {block} {{ {member}; }};\n",
                block.to_uppercase()
            ),
        };
    }
    let has = |x: Binding| {
        bindings
            .iter()
            .any(|b| matches!(b, ProbeBinding::Layout(y) if *y == x))
    };
    if BVH_BINDINGS.iter().all(|&b| has(b)) {
        s += "#define BVH_DECLARED\n";
    }
    if has(Binding::MeasuredTable) {
        s += "#ifdef MEASURED_TABLE\n#define MEASURED_TABLE_DECLARED\n#endif\n";
    }
    s += &format!(
        "layout(push_constant) uniform Push {{\n{}}} pc;\n#endif\n",
        block_fields(push)
    );
    s
}

/// The bindings `shaders/bvh.glsl` reads.
pub const BVH_BINDINGS: [Binding; 4] = [
    Binding::BvhNodes,
    Binding::BvhPrims,
    Binding::Triangles,
    Binding::Spheres,
];

/// `counter_<name>(…)`: the position of a [`CounterBlock`]'s entry, the formula of
/// [`layout::Counters::at`].
fn counter_function(b: CounterBlock) -> String {
    let row = b.row();
    let (per_queue, words) = b.start();
    let mut terms = vec![format!("{words}u")];
    if per_queue > 0 {
        terms.push(format!("{per_queue}u * g.num_queues"));
    }
    let (param, index) = match row.index {
        BlockIndex::None => ("", None),
        BlockIndex::Queue => ("uint k", Some("k".to_string())),
        BlockIndex::Segment => (
            "uint d",
            Some("(clamp(d, 1u, SEGMENTS_COUNTED) - 1u)".to_string()),
        ),
    };
    if let Some(i) = index {
        terms.push(format!("{}u * {i}", row.stride));
    }
    format!(
        "uint counter_{}({param}) {{ return {}; }}\n",
        row.name,
        terms.join(" + ")
    )
}

/// The generated header: the interface of every wavefront kernel.
pub fn glsl() -> String {
    let mut s = String::from(
        "// The wavefront kernels' interface, generated by src/gpu/interface.rs from the description\n\
         // in src/gpu/layout.rs and the Push / Globals structs: edit those, not this text.\n\
         #ifndef INTERFACE_GLSL\n#define INTERFACE_GLSL\n\n",
    );
    for (name, value) in layout::defines() {
        s += &format!("#define {name} {value}\n");
    }
    s += "\n";
    for b in Binding::ALL {
        s += &declaration(b);
    }
    s += "#define BVH_DECLARED\n";
    s += &format!(
        "\n// {}\nlayout(push_constant) uniform Push {{\n{}}} pc;\n\n",
        "Push constants (src/gpu/interface.rs `Push`).",
        block_fields(Push::FIELDS)
    );
    s += "// Counter positions (src/gpu/layout.rs `CounterBlock`).\n";
    for b in CounterBlock::ALL {
        s += &counter_function(b);
    }
    s += "\n#endif\n";
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Scalar layout: the Rust structs have exactly the words of their GLSL fields.
    #[test]
    fn blocks_are_packed_as_their_fields() {
        let words = |fields: &[Field]| -> usize {
            fields
                .iter()
                .map(|f| match f.glsl {
                    "uint" | "float" => 1,
                    "vec3" => 3,
                    t => panic!("{t}"),
                })
                .sum()
        };
        assert_eq!(std::mem::size_of::<Push>(), 4 * words(Push::FIELDS));
        assert_eq!(std::mem::size_of::<Globals>(), 4 * words(Globals::FIELDS));
        assert_eq!(Push::FIELDS[0].name, "depth");
        assert_eq!(Globals::FIELDS.last().unwrap().name, "focus_distance");
    }

    /// A probe's header numbers its bindings by position, declares each once, and says which
    /// included files' bindings it declares.
    #[test]
    fn a_probe_header_numbers_its_bindings_in_order() {
        let own = ProbeBinding::Storage {
            block: "Rays",
            member: "vec4 rays[]",
            access: "readonly",
            about: "rays",
        };
        let mut list = vec![own];
        list.extend(BVH_BINDINGS.map(ProbeBinding::Layout));
        let h = probe_glsl("P", &list, Push::FIELDS);
        assert!(h.contains("#define BINDING_RAYS 0\n"));
        assert!(h.contains("#define BINDING_BVH_NODES 1\n"));
        assert!(h.contains("#define BINDING_SPHERES 4\n"));
        assert!(h.contains(
            "layout(std430, set = 0, binding = BINDING_RAYS) readonly buffer Rays { vec4 rays[]; };"
        ));
        assert_eq!(h.matches("binding = BINDING_TRIANGLES,").count(), 1);
        assert!(h.contains("#define BVH_DECLARED"));
        assert!(!h.contains("MEASURED_TABLE_DECLARED"));
        assert!(h.contains("    uint wave_size;"));
        let partial = probe_glsl("Q", &list[..3], Push::FIELDS);
        assert!(!partial.contains("BVH_DECLARED"));
    }

    /// Every binding is declared once, at its define, with the image format of its texels.
    #[test]
    fn the_header_declares_every_binding_and_counter() {
        let h = glsl();
        for b in Binding::ALL {
            let at = format!("binding = BINDING_{})", b.name().to_uppercase());
            let at_fmt = format!("binding = BINDING_{},", b.name().to_uppercase());
            let n = h.matches(&at).count() + h.matches(&at_fmt).count();
            assert_eq!(n, 1, "{b:?} declared {n} times");
        }
        assert!(h.contains("layout(set = 0, binding = BINDING_HIT_REC, rgba32ui) uniform restrict uimageBuffer hit_rec_img;"));
        assert!(h.contains("layout(set = 0, binding = BINDING_RAY_O, rgba32f) uniform restrict imageBuffer ray_o_img;"));
        assert!(h.contains("buffer Counters { uint counters[]; };"));
        assert!(h.contains("    uint tile_width;"));
        for b in CounterBlock::ALL {
            assert!(h.contains(&format!("uint counter_{}(", b.row().name)));
        }
        // The formula as the host evaluates it, for 3 queues: FIXED + 2·3 + 1 + 2·(5 − 1).
        let c = layout::Counters { queues: 3 };
        let f = layout::FIXED_COUNTERS;
        assert_eq!(c.segment_extension(5) as u32, f + 2 * 3 + 1 + 2 * 4);
        assert!(h.contains(&format!(
            "uint counter_segment_extension(uint d) {{ return {}u + 2u * g.num_queues + 2u * (clamp(d, 1u, SEGMENTS_COUNTED) - 1u); }}",
            f + 1
        )));
    }
}
