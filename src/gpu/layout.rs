//! The wavefront integrator's GPU state, described once: every binding of set 0 (its name,
//! descriptor type and texel format), every counter and every indirect-dispatch slot. The
//! shaders get the same numbers as `#define`s generated from here at compile time
//! ([`defines`]); the renderer allocates, binds and reads back buffers by these names.
//!
//! Why texel buffers: lavapipe (Mesa's llvmpipe) runs 8 invocations as the lanes of one SIMD
//! vector. A storage-buffer access at a per-lane index becomes a loop over the lanes with a
//! branch and a bounds check per lane and per component, while an image load from a storage
//! texel buffer is a vector gather, inline, and a uniform-buffer read at a uniform offset is one
//! scalar load. (A `texelFetch` from a uniform texel buffer runs the same gather, but as an
//! out-of-line call around which every live vector register is spilled: Mesa 22.3 inlines it
//! only for RGBA8 unorm texels.) Scene data (read only, read at every BVH node and triangle) is
//! therefore bound as `readonly` storage texel buffers, the path state and the queues as
//! read-write ones, the scene-wide values as a uniform buffer; counters (atomics), indirect
//! arguments and the film stay storage buffers. docs/bench-log.md has the measurements.

use crate::conventions::SEGMENTS_COUNTED;
use ash::vk;

/// How a binding is declared and bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `uniform` block (small, read at uniform offsets).
    Uniform,
    /// `uniform readonly imageBuffer` read with `imageLoad`, in this format (scene data).
    ReadImage(vk::Format),
    /// `uniform imageBuffer` (read-write with imageLoad / imageStore), in this format.
    Image(vk::Format),
    /// `buffer` block (read-write, atomics).
    Storage,
}

/// One binding of set 0: its GLSL name is the define `BINDING_<NAME>` (upper case).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Binding {
    // Scene, read only.
    BvhNodes,
    BvhPrims,
    Triangles,
    Spheres,
    TriAttrs,
    Materials,
    Lights,
    Emitters,
    Globals,
    // Path state, one entry per path slot of the wave.
    RayO,
    RayD,
    Beta,
    Radiance,
    HitRec,
    ShadowO,
    ShadowD,
    ShadowL,
    // Queues, counters, indirect arguments, film.
    Queues,
    Counters,
    Args,
    Film,
    Film2,
    // Measured materials' tables, read only (declared under MEASURED_TABLE only).
    MeasuredTable,
    // Images (the environment map, textures) and the environment map's distribution, read
    // only (declared under SCENE_IMAGES and SCENE_ENV_MAP only).
    Images,
    EnvDist,
    // The textures' headers and the textured materials' lists (declared under SCENE_TEXTURES).
    TexInfo,
}

impl Binding {
    /// Every binding, in binding-number order.
    pub const ALL: [Binding; 26] = [
        Binding::BvhNodes,
        Binding::BvhPrims,
        Binding::Triangles,
        Binding::Spheres,
        Binding::TriAttrs,
        Binding::Materials,
        Binding::Lights,
        Binding::Emitters,
        Binding::Globals,
        Binding::RayO,
        Binding::RayD,
        Binding::Beta,
        Binding::Radiance,
        Binding::HitRec,
        Binding::ShadowO,
        Binding::ShadowD,
        Binding::ShadowL,
        Binding::Queues,
        Binding::Counters,
        Binding::Args,
        Binding::Film,
        Binding::Film2,
        Binding::MeasuredTable,
        Binding::Images,
        Binding::EnvDist,
        Binding::TexInfo,
    ];

    /// The binding number.
    pub fn index(self) -> u32 {
        self as u32
    }

    /// The buffer's name (debug names, messages) and, upper-cased, the GLSL define's suffix.
    pub fn name(self) -> &'static str {
        match self {
            Binding::BvhNodes => "bvh_nodes",
            Binding::BvhPrims => "bvh_prims",
            Binding::Triangles => "triangles",
            Binding::Spheres => "spheres",
            Binding::TriAttrs => "tri_attrs",
            Binding::Materials => "materials",
            Binding::Lights => "lights",
            Binding::Emitters => "emitters",
            Binding::Globals => "globals",
            Binding::RayO => "ray_o",
            Binding::RayD => "ray_d",
            Binding::Beta => "beta",
            Binding::Radiance => "radiance",
            Binding::HitRec => "hit_rec",
            Binding::ShadowO => "shadow_o",
            Binding::ShadowD => "shadow_d",
            Binding::ShadowL => "shadow_l",
            Binding::Queues => "queues",
            Binding::Counters => "counters",
            Binding::Args => "args",
            Binding::Film => "film",
            Binding::Film2 => "film2",
            Binding::MeasuredTable => "measured_table",
            Binding::Images => "images",
            Binding::EnvDist => "env_dist",
            Binding::TexInfo => "tex_info",
        }
    }

    /// A record one of the separate wavefront stages leaves for the next (the hit record from
    /// `extend` for `shade`, the shadow ray from `shade` for `shadow`): read and written only by
    /// the kernels of `stages::Schedule::Wavefront`, so the other schedules get it as one
    /// texel (`stages::separate_stages`).
    pub fn is_stage_record(self) -> bool {
        matches!(
            self,
            Binding::HitRec | Binding::ShadowO | Binding::ShadowD | Binding::ShadowL
        )
    }

    pub fn kind(self) -> Kind {
        use vk::Format as F;
        match self {
            Binding::BvhNodes
            | Binding::Triangles
            | Binding::Spheres
            | Binding::TriAttrs
            | Binding::Materials
            | Binding::Emitters
            | Binding::TexInfo => Kind::ReadImage(F::R32G32B32A32_UINT),
            Binding::MeasuredTable | Binding::Images => Kind::ReadImage(F::R32G32B32A32_SFLOAT),
            Binding::EnvDist => Kind::ReadImage(F::R32_SFLOAT),
            Binding::BvhPrims => Kind::ReadImage(F::R32_UINT),
            Binding::Lights => Kind::ReadImage(F::R32G32_UINT),
            Binding::Globals => Kind::Uniform,
            Binding::RayO
            | Binding::RayD
            | Binding::Beta
            | Binding::Radiance
            | Binding::ShadowO
            | Binding::ShadowD
            | Binding::ShadowL => Kind::Image(F::R32G32B32A32_SFLOAT),
            Binding::HitRec => Kind::Image(F::R32G32B32A32_UINT),
            Binding::Queues => Kind::Image(F::R32_UINT),
            Binding::Counters | Binding::Args | Binding::Film | Binding::Film2 => Kind::Storage,
        }
    }

    pub fn descriptor_type(self) -> vk::DescriptorType {
        match self.kind() {
            Kind::Uniform => vk::DescriptorType::UNIFORM_BUFFER,
            Kind::ReadImage(_) => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
            Kind::Image(_) => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
            Kind::Storage => vk::DescriptorType::STORAGE_BUFFER,
        }
    }

    /// Its name in GLSL (a block's instance or member name) and what it holds, for the
    /// declaration in the generated interface ([`super::interface::glsl`]).
    pub fn glsl(self) -> (&'static str, &'static str) {
        match self {
            Binding::BvhNodes => ("bvh_nodes", "4 texels per node: (lmin, left), (lmax, right), (rmin, left_count), (rmax, right_count); the u32 fields as bits in .w (src/bvh/node.rs)"),
            Binding::BvhPrims => ("bvh_prims", "primitive references: triangle index, or sphere index | BVH_SPHERE_BIT"),
            Binding::Triangles => ("tri_data", "3 texels per triangle: (v0, material bits), (v1, emitter bits or 0xFFFFFFFF), (v2, unused)"),
            Binding::Spheres => ("sphere_data", "3 texels per sphere: (center, radius), (material bits, emitter bits, inward bits, frame flags bits), the frame's quaternion (src/scene/mod.rs SphereFrame)"),
            Binding::TriAttrs => ("tri_attrs", "4 texels per triangle: (n0, u0), (n1, u1), (n2, u2), (v0, v1, v2, flags)"),
            Binding::Materials => ("material_words", "the material records (src/brdf/mod.rs)"),
            Binding::Lights => ("light_table", "(prim ref, floatBits(cdf)) per emitting primitive"),
            Binding::Emitters => ("emitter_data", "radiance, lum(Le)/W per emitter"),
            Binding::Globals => ("g", "scene-wide values, read at uniform offsets (one load each)"),
            Binding::RayO => ("ray_o_img", "xyz origin (megakernel: w = depth of the path to resume, 0 once ended)"),
            Binding::RayD => ("ray_d_img", "xyz direction, w = pdf of the BSDF sample (0: camera/delta)"),
            Binding::Beta => ("beta_img", "xyz path throughput, w the triangle the ray leaves (bvh_leaving_code)"),
            Binding::Radiance => ("radiance_img", "radiance gathered along the path"),
            Binding::HitRec => ("hit_rec_img", "prim, bary.x, bary.y, t (float bits)"),
            Binding::ShadowO => ("shadow_o_img", "xyz origin, w = tmax"),
            Binding::ShadowD => ("shadow_d_img", "xyz direction, w the triangle it leaves (bvh_leaving_code)"),
            Binding::ShadowL => ("shadow_l_img", "unoccluded contribution"),
            Binding::Queues => ("queue_img", "path indices: the regions of `Queue`, wave_paths entries each"),
            Binding::Counters => ("counters", "`Counter`, then the `CounterBlock`s: queue lengths, non-finite counts, ray totals"),
            Binding::Args => ("args", "indirect dispatch arguments (x, y, z, pad) per `Args` slot"),
            Binding::Film => ("film", "running sums of radiance per pixel, .w the scale exponent k (accumulate.comp)"),
            Binding::Film2 => ("film2", "running sums of radiance² per pixel"),
            Binding::MeasuredTable => ("measured_table", "one texel per MERL cell of every distinct measured table, (f_r red, green, blue, unused), negative = missing (src/brdf/measured.rs)"),
            Binding::Images => ("image_texels", "(r, g, b, unused) texels of the scene's images, row by row: the environment map's radiance first (src/envmap.rs), then the textures (src/texture.rs)"),
            Binding::TexInfo => ("texture_info", "texel 0 unused, 3 texels per texture ((first texel, width, height, filter | wrap << 4), to_uv's two rows), then each textured material's list at its record's header.w: (count), (texture, record word, slot mode) per parameter (src/texture.rs, shaders/texture.glsl)"),
            Binding::EnvDist => ("env_dist_data", "the environment map's marginal CDF (H values), its rows' conditional CDFs ((H - 1) x (W + 1)) and its cells' densities in (u, v) ((H - 1) x W) (src/envmap.rs)"),
        }
    }

    /// The define under which the binding is declared, for one only some kernels read: a
    /// scene without measured materials compiles the kernels it compiled before the binding
    /// existed.
    pub fn condition(self) -> Option<&'static str> {
        match self {
            Binding::MeasuredTable => Some("MEASURED_TABLE"),
            Binding::Images => Some("SCENE_IMAGES"),
            Binding::EnvDist => Some("SCENE_ENV_MAP"),
            Binding::TexInfo => Some("SCENE_TEXTURES"),
            _ => None,
        }
    }

    /// The element type of a storage-buffer binding's array.
    pub fn storage_element(self) -> Option<&'static str> {
        match self {
            Binding::Counters => Some("uint"),
            Binding::Args => Some("uvec4"),
            Binding::Film | Binding::Film2 => Some("vec4"),
            _ => None,
        }
    }

    /// The buffer usage the binding needs.
    pub fn usage(self) -> vk::BufferUsageFlags {
        match self.kind() {
            Kind::Uniform => vk::BufferUsageFlags::UNIFORM_BUFFER,
            Kind::ReadImage(_) => vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER,
            Kind::Image(_) => vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER,
            Kind::Storage => vk::BufferUsageFlags::STORAGE_BUFFER,
        }
    }
}

/// Declares a fixed list of numbered slots as an enum and, with each slot, the `#define` the
/// shaders know it by: the numbers are the declaration order, so adding a slot is one line
/// (and its use in a shader), and nothing after it needs renumbering by hand.
macro_rules! slots {
    ($(#[$enum_doc:meta])* $enum:ident { $($(#[$doc:meta])* $name:ident => $define:literal,)* }) => {
        $(#[$enum_doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $enum {
            $($(#[$doc])* $name,)*
        }

        impl $enum {
            /// Every slot, in order, with its `#define` name.
            pub const ALL: &'static [($enum, &'static str)] = &[$(($enum::$name, $define),)*];

            /// Its number (the position in [`Self::ALL`]).
            pub fn index(self) -> u32 {
                self as u32
            }
        }
    };
}

slots! {
    /// The counters (one u32 each) in binding `counters`: these fixed ones first, then per
    /// material queue k its length, then the non-finite counts of `extend` and of each shade
    /// kernel, then the rays by segment ([`Counters`]).
    Counter {
    /// Lengths of the two ping-pong ray queues.
    RayQueue0 => "COUNTER_RAY",
    RayQueue1 => "COUNTER_RAY_1",
    /// Length of the shadow-ray queue.
    ShadowQueue => "COUNTER_SHADOW",
    /// Non-finite samples dropped by `accumulate`.
    NonfiniteAccumulate => "COUNTER_NONFINITE",
    /// 64-bit running totals (low word, high word) of extension and shadow rays traced.
    ExtensionRaysLo => "COUNTER_EXT_TOTAL",
    ExtensionRaysHi => "COUNTER_EXT_TOTAL_HI",
    ShadowRaysLo => "COUNTER_SHADOW_TOTAL",
    ShadowRaysHi => "COUNTER_SHADOW_TOTAL_HI",
    /// 64-bit running total (low word, high word) of shadow rays that found an occluder.
    OccludedLo => "COUNTER_OCCLUDED_TOTAL",
    OccludedHi => "COUNTER_OCCLUDED_TOTAL_HI",
    /// Invocations whose loops the driver cut short (state.glsl `check_loops`): an error.
    CutShort => "COUNTER_CUT_SHORT",
    /// Running count of the paths the megakernel stopped before their end, to be resumed by
    /// the next dispatch (megakernel.comp).
    MegakernelResumed => "COUNTER_RESUMED",
}
}

/// Invocations per workgroup of every wavefront kernel but the one-thread `prepare` (the shaders'
/// `LOCAL_SIZE`; each pipeline's reflected size is checked against it).
pub const LOCAL_SIZE: u32 = 64;

// The megakernel clears and adds its per-segment ray counts with one invocation per segment.
const _: () = assert!(SEGMENTS_COUNTED <= LOCAL_SIZE);

/// Counters before the per-queue ones.
pub const FIXED_COUNTERS: u32 = Counter::ALL.len() as u32;

/// The blocks of counters after the fixed ones, in order. Each is sized by the scene's number of
/// material queues; [`CounterBlock::row`] is the one description of where each counter is, which
/// both [`Counters`] (the host) and the generated GLSL functions `counter_<name>` ([`glsl`])
/// evaluate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CounterBlock {
    /// Length of material queue k.
    MaterialQueue,
    /// Non-finite emitted values dropped by `extend`.
    NonfiniteExtend,
    /// Non-finite values dropped by the shade kernel of material queue k.
    NonfiniteShade,
    /// 64-bit counts (low word, high word) of the extension rays of path segment d (1-based;
    /// the last counted segment also holds all deeper ones).
    SegmentExtension,
    /// The same for the shadow rays traced from the vertex at the end of segment d.
    SegmentShadow,
}

/// What a counter block's entry is numbered by.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockIndex {
    /// One entry.
    None,
    /// A material queue k (0-based).
    Queue,
    /// A path segment d, 1-based, clamped to 1 ..= [`SEGMENTS_COUNTED`].
    Segment,
}

/// One block of counters: `per_queue` × queues + `words` counters, an entry every `stride`.
#[derive(Clone, Copy, Debug)]
pub struct BlockRow {
    /// The GLSL function is `counter_<name>`.
    pub name: &'static str,
    pub per_queue: u32,
    pub words: u32,
    pub stride: u32,
    pub index: BlockIndex,
}

impl CounterBlock {
    pub const ALL: [CounterBlock; 5] = [
        CounterBlock::MaterialQueue,
        CounterBlock::NonfiniteExtend,
        CounterBlock::NonfiniteShade,
        CounterBlock::SegmentExtension,
        CounterBlock::SegmentShadow,
    ];

    pub fn row(self) -> BlockRow {
        let (name, per_queue, words, stride, index) = match self {
            CounterBlock::MaterialQueue => ("material_queue", 1, 0, 1, BlockIndex::Queue),
            CounterBlock::NonfiniteExtend => ("nonfinite_extend", 0, 1, 0, BlockIndex::None),
            CounterBlock::NonfiniteShade => ("nonfinite_shade", 1, 0, 1, BlockIndex::Queue),
            CounterBlock::SegmentExtension => (
                "segment_extension",
                0,
                2 * SEGMENTS_COUNTED,
                2,
                BlockIndex::Segment,
            ),
            CounterBlock::SegmentShadow => (
                "segment_shadow",
                0,
                2 * SEGMENTS_COUNTED,
                2,
                BlockIndex::Segment,
            ),
        };
        BlockRow {
            name,
            per_queue,
            words,
            stride,
            index,
        }
    }

    /// Where the block starts, as (per queue, words): the fixed counters and every block
    /// before it.
    pub fn start(self) -> (u32, u32) {
        let mut start = (0, FIXED_COUNTERS);
        for b in Self::ALL.into_iter().take_while(|&b| b != self) {
            start = (start.0 + b.row().per_queue, start.1 + b.row().words);
        }
        start
    }
}

/// Where each counter of a scene with `queues` material queues is.
#[derive(Clone, Copy, Debug)]
pub struct Counters {
    pub queues: u32,
}

impl Counters {
    pub fn fixed(self, c: Counter) -> usize {
        c as usize
    }
    /// Entry `i` of block `b` (a queue k or a segment d, as the block's [`BlockIndex`] says;
    /// ignored for a single entry).
    pub fn at(self, b: CounterBlock, i: u32) -> usize {
        let (per_queue, words) = b.start();
        let row = b.row();
        let i = match row.index {
            BlockIndex::None => 0,
            BlockIndex::Queue => i,
            BlockIndex::Segment => i.clamp(1, SEGMENTS_COUNTED) - 1,
        };
        (per_queue * self.queues + words + row.stride * i) as usize
    }
    /// Length of material queue k.
    pub fn material_queue(self, k: u32) -> usize {
        self.at(CounterBlock::MaterialQueue, k)
    }
    /// Non-finite emitted values dropped by `extend`.
    pub fn nonfinite_extend(self) -> usize {
        self.at(CounterBlock::NonfiniteExtend, 0)
    }
    /// Non-finite values dropped by the shade kernel of material queue k.
    pub fn nonfinite_shade(self, k: u32) -> usize {
        self.at(CounterBlock::NonfiniteShade, k)
    }
    /// 64-bit count (low word) of the extension rays of path segment `d` (1-based; the last
    /// counted segment also holds all deeper ones).
    pub fn segment_extension(self, d: u32) -> usize {
        self.at(CounterBlock::SegmentExtension, d)
    }
    /// The same for the shadow rays traced from the vertex at the end of segment `d`.
    pub fn segment_shadow(self, d: u32) -> usize {
        self.at(CounterBlock::SegmentShadow, d)
    }
    /// How many counters there are: the end of the last block.
    pub fn len(self) -> usize {
        let (per_queue, words) = CounterBlock::ALL.iter().fold((0, FIXED_COUNTERS), |s, b| {
            (s.0 + b.row().per_queue, s.1 + b.row().words)
        });
        (per_queue * self.queues + words) as usize
    }
    pub fn is_empty(self) -> bool {
        false
    }
    /// Length of ray queue `q` (`Queue::Ray0` or `Queue::Ray1`): the ray-queue counters are in
    /// the order of their queues.
    pub fn ray_queue(self, q: Queue) -> usize {
        debug_assert!(
            matches!(q, Queue::Ray0 | Queue::Ray1),
            "{q:?} is no ray queue"
        );
        (Counter::RayQueue0.index() + q.index() - Queue::Ray0.index()) as usize
    }
    /// A 64-bit total kept in two words from `lo`.
    pub fn total(self, values: &[u32], lo: Counter) -> u64 {
        self.total_at(values, lo as usize)
    }
    /// A 64-bit total kept in two words from position `lo`.
    pub fn total_at(self, values: &[u32], lo: usize) -> u64 {
        values[lo] as u64 | (values[lo + 1] as u64) << 32
    }
}

slots! {
    /// Indirect-dispatch argument slots (4 u32 each: x, y, z, pad) in binding `args`: these
    /// fixed ones, then one per material queue ([`Args::material`]).
    Args {
    /// The extension rays of the segment (`extend`, or `extend_shade_<model>`).
    Ray => "ARGS_RAY",
    /// The shadow queue (`shadow`).
    Shadow => "ARGS_SHADOW",
}
}

impl Args {
    /// The slot of material queue k (`shade_<model>`).
    pub fn material(k: u32) -> u32 {
        Self::ALL.len() as u32 + k
    }
    /// How many slots a scene with `queues` material queues has.
    pub fn len(queues: u32) -> u32 {
        Self::material(queues)
    }
}

slots! {
    /// Queue regions of binding `queues`, `wave_paths` entries each: these fixed ones, then one
    /// per material queue ([`Queue::material`]). The region of a queue is also the offset of its
    /// length from the first of its counters (`Counter::RayQueue0`), for the ray queues.
    Queue {
    /// The two ping-pong ray queues: segment d reads queue (d + 1) mod 2 and its shade stage
    /// writes the other one.
    Ray0 => "QUEUE_RAY",
    Ray1 => "QUEUE_RAY_1",
    /// Shadow rays of the segment, written by the shade kernels.
    Shadow => "QUEUE_SHADOW",
}
}

impl Queue {
    /// The region of material queue k.
    pub fn material(k: u32) -> u32 {
        Self::ALL.len() as u32 + k
    }
    /// How many regions a scene with `queues` material queues has.
    pub fn len(queues: u32) -> u32 {
        Self::material(queues)
    }
    /// The ray queue that holds the rays of segment `depth` (segment 1 reads queue 0).
    pub fn ray_in(depth: u32) -> Queue {
        match depth % 2 {
            1 => Queue::Ray0,
            _ => Queue::Ray1,
        }
    }
}

slots! {
    /// What the one-thread `prepare` kernel does (push constant `phase`): each phase writes the
    /// indirect arguments of the stage it comes before.
    Prepare {
    /// Before `extend`: its arguments from the ray queue, the ray totals, and empty queues for
    /// what the segment appends.
    Extend => "PREPARE_EXTEND",
    /// Before the shade kernels: the arguments of each material queue.
    Shade => "PREPARE_SHADE",
    /// Before `shadow`: its arguments from the shadow queue, and the shadow-ray totals.
    Shadow => "PREPARE_SHADOW",
}
}

slots! {
    /// What a megakernel dispatch does (push constant `phase`).
    MegakernelPhase {
    /// Start every path of the wave at the camera.
    Start => "MEGAKERNEL_START",
    /// Resume the paths the driver's loop budget stopped (megakernel.comp).
    Resume => "MEGAKERNEL_RESUME",
}
}

/// The numbers of the interface, as `#define`s of the generated header
/// ([`super::interface::glsl`]): binding numbers, fixed counters, argument and queue slots, the
/// phases of `prepare` and of the megakernel, the local size.
pub fn defines() -> Vec<(String, String)> {
    let mut d: Vec<(String, String)> = Binding::ALL
        .iter()
        .map(|b| {
            (
                format!("BINDING_{}", b.name().to_uppercase()),
                b.index().to_string(),
            )
        })
        .collect();
    let c = |name: &str, v: u32| (name.to_string(), format!("{v}u"));
    d.extend(Counter::ALL.iter().map(|&(k, name)| c(name, k.index())));
    d.extend(Args::ALL.iter().map(|&(k, name)| c(name, k.index())));
    d.extend(Queue::ALL.iter().map(|&(k, name)| c(name, k.index())));
    d.extend(Prepare::ALL.iter().map(|&(k, name)| c(name, k.index())));
    d.extend(
        MegakernelPhase::ALL
            .iter()
            .map(|&(k, name)| c(name, k.index())),
    );
    d.extend([
        ("LOCAL_SIZE".to_string(), LOCAL_SIZE.to_string()),
        c("ARGS_MATERIAL", Args::material(0)),
        c("QUEUE_MATERIAL", Queue::material(0)),
        c("SEGMENTS_COUNTED", SEGMENTS_COUNTED),
    ]);
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bindings_are_numbered_in_order_and_named_once() {
        for (i, b) in Binding::ALL.iter().enumerate() {
            assert_eq!(b.index() as usize, i);
        }
        let mut names: Vec<_> = Binding::ALL.iter().map(|b| b.name()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), Binding::ALL.len());
    }

    /// Every table of slots is numbered in declaration order and names each slot once, with
    /// its table's prefix.
    fn check_slots<T: Copy + std::fmt::Debug>(
        all: &[(T, &str)],
        index: fn(T) -> u32,
        prefix: &str,
    ) {
        for (i, &(k, name)) in all.iter().enumerate() {
            assert_eq!(index(k) as usize, i, "{k:?}");
            assert!(name.starts_with(prefix), "{name} is not {prefix}*");
            assert_eq!(all.iter().filter(|(_, n)| *n == name).count(), 1, "{name}");
        }
    }

    #[test]
    fn slots_are_numbered_in_order_with_distinct_defines() {
        check_slots(Counter::ALL, Counter::index, "COUNTER_");
        check_slots(Args::ALL, Args::index, "ARGS_");
        check_slots(Queue::ALL, Queue::index, "QUEUE_");
        check_slots(Prepare::ALL, Prepare::index, "PREPARE_");
        check_slots(MegakernelPhase::ALL, MegakernelPhase::index, "MEGAKERNEL_");
        let names: Vec<String> = defines().into_iter().map(|(n, _)| n).collect();
        for n in &names {
            assert_eq!(
                names.iter().filter(|m| *m == n).count(),
                1,
                "{n} defined twice"
            );
        }
    }

    /// The block table gives the positions the hand-written formulas gave before it.
    #[test]
    fn counter_blocks_give_the_former_positions() {
        let f = FIXED_COUNTERS as usize;
        for q in [1u32, 2, 8] {
            let c = Counters { queues: q };
            let qq = q as usize;
            assert_eq!(c.material_queue(1), f + 1);
            assert_eq!(c.nonfinite_extend(), f + qq);
            assert_eq!(c.nonfinite_shade(1), f + qq + 2);
            assert_eq!(c.segment_extension(3), f + 2 * qq + 1 + 4);
            assert_eq!(c.segment_shadow(3), c.segment_extension(3) + 64);
            assert_eq!(c.segment_shadow(99), c.segment_shadow(32));
            assert_eq!(c.segment_shadow(0), c.segment_shadow(1));
            assert_eq!(c.len(), f + 2 * qq + 1 + 4 * 32);
        }
    }

    /// The shaders index the ray queues and their counters by `ray_queue_in()` from the first.
    #[test]
    fn ray_queues_alternate_and_their_counters_follow_them() {
        let c = Counters { queues: 2 };
        assert_eq!(Queue::ray_in(1), Queue::Ray0);
        assert_eq!(Queue::ray_in(2), Queue::Ray1);
        assert_eq!(Queue::ray_in(3), Queue::Ray0);
        assert_eq!(Queue::Ray1.index(), Queue::Ray0.index() + 1);
        assert_eq!(c.ray_queue(Queue::Ray0), Counter::RayQueue0 as usize);
        assert_eq!(c.ray_queue(Queue::Ray1), Counter::RayQueue1 as usize);
        assert_eq!(Queue::len(2), Queue::material(1) + 1);
        assert_eq!(Args::len(2), Args::material(1) + 1);
    }

    #[test]
    fn counters_do_not_overlap() {
        let c = Counters { queues: 3 };
        let mut all: Vec<usize> = (0..FIXED_COUNTERS as usize).collect();
        all.extend((0..3).map(|k| c.material_queue(k)));
        all.push(c.nonfinite_extend());
        all.extend((0..3).map(|k| c.nonfinite_shade(k)));
        for d in 1..=SEGMENTS_COUNTED {
            all.extend([c.segment_extension(d), c.segment_extension(d) + 1]);
            all.extend([c.segment_shadow(d), c.segment_shadow(d) + 1]);
        }
        assert_eq!(
            c.segment_extension(SEGMENTS_COUNTED + 5),
            c.segment_extension(SEGMENTS_COUNTED)
        );
        let n = all.len();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), n);
        assert_eq!(*all.last().unwrap() + 1, c.len());
    }
}
