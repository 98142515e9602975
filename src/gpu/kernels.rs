//! The Vulkan objects of a renderer: one buffer per [`Binding`] of the layout, and the kernels
//! (pipelines with their descriptor sets) its [`Schedule`] dispatches, built from the stage
//! table ([`Stage`]) with the defines every kernel shares.

use super::interface::{self, Push};
use super::layout::{self, Binding, Counters, Kind, Queue};
use super::stages::{separate_stages, ModelQueue, Schedule, ShadeKernel, Stage, WaveKernels};
use super::{scene_buffers, Integrator, SetupStats};
use crate::brdf::glsl::model_define;
use crate::brdf::MODELS;
use crate::bvh::Bvh;
use crate::film::Tile;
use crate::lights::LightTable;
use crate::scene::Scene;
use crate::vk::{Buffer, ComputePipeline, Context, Resource, ShaderCompiler};
use anyhow::{bail, Context as _, Result};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::collections::BTreeSet;
use std::sync::Arc;
use std::time::Instant;

/// (name, value) pairs: `#define`s, or include overrides (virtual name, file).
pub(crate) type Defines = Vec<(String, String)>;

pub(super) struct Kernel {
    pub pipeline: ComputePipeline,
    pub set: vk::DescriptorSet,
}

/// A kernel of [`Owned::kernels`]: made only by [`Builder::build`], so it always names one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct KernelId(usize);

/// The Vulkan objects a renderer made, destroyed when it goes (also when set-up fails half way).
pub(super) struct Owned<'a> {
    ctx: &'a Context,
    /// One buffer per [`Binding`], in binding order.
    buffers: Vec<Buffer>,
    /// Texel views, parallel to `buffers` (null for whole-buffer bindings).
    views: Vec<vk::BufferView>,
    kernels: Vec<Kernel>,
}

impl Owned<'_> {
    pub fn buffer(&self, b: Binding) -> &Buffer {
        &self.buffers[b.index() as usize]
    }
    pub fn kernel(&self, k: KernelId) -> &Kernel {
        &self.kernels[k.0]
    }
    fn resources(&self) -> Vec<Resource<'_>> {
        self.buffers
            .iter()
            .zip(&self.views)
            .map(|(b, &v)| match v == vk::BufferView::null() {
                true => Resource::Buffer(b),
                false => Resource::Texels(b, v),
            })
            .collect()
    }
}

impl Drop for Owned<'_> {
    fn drop(&mut self) {
        for k in self.kernels.drain(..) {
            self.ctx.destroy_pipeline(k.pipeline);
        }
        for v in self.views.drain(..) {
            if v != vk::BufferView::null() {
                self.ctx.destroy_buffer_view(v);
            }
        }
        for b in self.buffers.drain(..) {
            self.ctx.destroy_buffer(b);
        }
    }
}

/// What the buffers of a render are sized for.
pub(super) struct Sizes {
    pub wave_paths: u32,
    pub counters: Counters,
    pub tile: Tile,
    /// Whether the schedule runs the separate stages, which alone use the stage records
    /// ([`Binding::is_stage_record`]; [`super::stages::separate_stages`]).
    pub separate_stages: bool,
}

/// Uploads the scene and allocates the path state, queues, counters and film: one buffer (and
/// texel view, for texel bindings) per [`Binding`], sized by `sizes`. `bvh` is dropped as soon
/// as its two buffers are made (the first two bindings), so that the host's copy of the tree,
/// when this was its last reference, is not held beside everything made after them.
pub(super) fn create_buffers<'a>(
    ctx: &'a Context,
    scene: &Scene,
    bvh: Arc<Bvh>,
    sizes: &Sizes,
) -> Result<Owned<'a>> {
    let Sizes {
        wave_paths,
        counters,
        tile,
        separate_stages,
    } = *sizes;
    let num_queues = counters.queues;
    let lights = LightTable::build(scene);
    let film_bytes = tile.pixels() as u64 * 16;
    let limit = ctx.limits.max_storage_buffer_range as u64;
    let queue_bytes = Queue::len(num_queues) as u64 * wave_paths as u64 * 4;
    if film_bytes > limit || queue_bytes > limit {
        bail!(
            "{}: its film needs {} MiB, over this device's storage-buffer range of {} MiB; render a smaller image or split it into tiles (--tile)",
            if tile == Tile::full(scene.width, scene.height) {
                format!("an image of {}x{}", scene.width, scene.height)
            } else {
                format!("a tile of {}x{}", tile.width, tile.height)
            },
            film_bytes >> 20,
            limit >> 20
        );
    }
    let queue_slot = scene_buffers::queue_slots(scene);
    let mut owned = Owned {
        ctx,
        buffers: Vec::new(),
        views: Vec::new(),
        kernels: Vec::new(),
    };
    let cap = wave_paths as u64;
    let gpu = MemoryLocation::GpuOnly;
    let mut bvh = Some(bvh);
    for b in Binding::ALL {
        let tree = || bvh.as_deref().expect("the tree's bindings come first");
        let name = b.name();
        let usage = b.usage();
        let data = |bytes: &[u8]| ctx.create_buffer_with_data(name, bytes, usage);
        let buffer = match b {
            Binding::BvhNodes => data(scene_buffers::bvh_nodes(tree()))?,
            Binding::BvhPrims => data(bytemuck::cast_slice(&tree().prims))?,
            Binding::Triangles => ctx.create_buffer_filled(
                name,
                scene.triangles.len() * scene_buffers::TRIANGLE_TEXELS,
                usage,
                |texels: &mut [[f32; 4]]| scene_buffers::write_triangle_data(scene, texels),
            )?,
            Binding::Spheres => data(bytemuck::cast_slice(&scene_buffers::sphere_data(scene)))?,
            Binding::TriAttrs => data(bytemuck::cast_slice(&scene_buffers::triangle_attributes(
                scene,
            )))?,
            Binding::Materials => data(bytemuck::cast_slice(&scene_buffers::material_records(
                scene,
                &queue_slot,
            )))?,
            Binding::Lights => data(bytemuck::cast_slice(&scene_buffers::light_data(&lights)))?,
            Binding::Emitters => data(bytemuck::cast_slice(&scene_buffers::emitter_data(
                scene, &lights,
            )))?,
            Binding::Globals => data(bytemuck::bytes_of(&scene_buffers::globals(
                scene, &lights, num_queues, wave_paths, tile,
            )))?,
            Binding::RayO
            | Binding::RayD
            | Binding::Beta
            | Binding::Radiance
            | Binding::HitRec
            | Binding::ShadowO
            | Binding::ShadowD
            | Binding::ShadowL => {
                // A schedule without the separate stages never touches their records: one
                // texel each instead of 16 bytes a path (64 MB at the default wave of 2^20).
                let texels = match b.is_stage_record() && !separate_stages {
                    true => 1,
                    false => cap,
                };
                ctx.create_buffer(name, texels * 16, usage, gpu)?
            }
            Binding::Queues => ctx.create_buffer(name, queue_bytes, usage, gpu)?,
            // Film and counters are read and written by every pass and read back once: device
            // memory, downloaded through a staging copy (in host-visible memory every accumulate
            // would cross PCIe on a discrete GPU).
            Binding::Counters => ctx.create_buffer(name, counters.len() as u64 * 4, usage, gpu)?,
            Binding::Args => ctx.create_buffer(
                name,
                layout::Args::len(num_queues) as u64 * 16,
                usage | vk::BufferUsageFlags::INDIRECT_BUFFER,
                gpu,
            )?,
            Binding::Film | Binding::Film2 => ctx.create_buffer(name, film_bytes, usage, gpu)?,
            Binding::MeasuredTable => data(bytemuck::cast_slice(
                &scene_buffers::MeasuredTables::of(&scene.materials).texels(),
            ))?,
            Binding::Images => data(bytemuck::cast_slice(&scene_buffers::image_texels(scene)))?,
            Binding::EnvDist => data(bytemuck::cast_slice(&scene_buffers::env_dist(scene)))?,
            Binding::TexInfo => data(bytemuck::cast_slice(
                &scene_buffers::TextureTable::of(scene).info,
            ))?,
        };
        owned.buffers.push(buffer);
        if b == Binding::BvhPrims {
            bvh = None;
        }
        let view = match b.kind() {
            Kind::ReadImage(format) | Kind::Image(format) => {
                ctx.create_buffer_view(owned.buffers.last().unwrap(), format)?
            }
            Kind::Uniform | Kind::Storage => vk::BufferView::null(),
        };
        owned.views.push(view);
    }
    Ok(owned)
}

/// Compiles kernels and creates their pipelines and descriptor sets into [`Owned`], each with
/// the defines every kernel shares.
struct Builder<'b, 'a> {
    ctx: &'a Context,
    compiler: &'b ShaderCompiler,
    owned: &'b mut Owned<'a>,
    setup: &'b mut SetupStats,
    common: Defines,
    /// The generated sources every kernel can include: the interface header.
    generated: Defines,
    kinds: Vec<vk::DescriptorType>,
}

impl Builder<'_, '_> {
    /// The kernel of `stage` as pipeline `name`, compiled with `defines` and include `overrides`
    /// on top of the common defines.
    fn build(
        &mut self,
        stage: Stage,
        name: &str,
        mut defines: Defines,
        overrides: Defines,
    ) -> Result<KernelId> {
        let file = stage.file();
        defines.extend(self.common.iter().cloned());
        let t = Instant::now();
        let spirv = self
            .compiler
            .compile_generated(file, &defines, &overrides, &self.generated)
            .with_context(|| format!("compiling {file} for pipeline {name}"))?
            .spirv;
        self.setup.seconds_shader_compile += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let pipeline = self.ctx.create_compute_pipeline_with(
            name,
            &spirv,
            &self.kinds,
            std::mem::size_of::<Push>() as u32,
        )?;
        self.setup.seconds_pipeline_create += t.elapsed().as_secs_f64();
        if pipeline.local_size_x != stage.local_size() {
            let size = pipeline.local_size_x;
            self.ctx.destroy_pipeline(pipeline);
            bail!(
                "{file} has local_size_x = {size}, but the host dispatches it in workgroups of {} (gpu::stages::Stage::local_size)",
                stage.local_size()
            );
        }
        let set = match self
            .ctx
            .create_descriptor_set_with(&pipeline, &self.owned.resources())
        {
            Ok(set) => set,
            Err(e) => {
                self.ctx.destroy_pipeline(pipeline);
                return Err(e);
            }
        };
        self.setup.pipelines.push(name.to_string());
        self.owned.kernels.push(Kernel { pipeline, set });
        Ok(KernelId(self.owned.kernels.len() - 1))
    }

    /// A kernel of a stage that is the same for every model.
    fn stage(&mut self, stage: Stage) -> Result<KernelId> {
        self.build(stage, stage.name(), vec![], vec![])
    }

    /// `stage` (a per-model stage) compiled for `model`, pipeline `<stage>_<model>`.
    fn model_stage(&mut self, stage: Stage, scene: &Scene, model: usize) -> Result<KernelId> {
        let (defs, overrides) = model_shader_inputs(model, model_features(scene, model));
        let name = format!("{}_{}", stage.name(), MODELS[model].name);
        self.build(stage, &name, defs, overrides)
    }
}

/// The defines added to every kernel (the layout's numbers come with the generated interface
/// header instead): the sampler and its dimension table, subgroup-aggregated queue pushes where the device has subgroup ballots (see
/// `queue_push` in state.glsl), the tile mapping (see `path_pixel`), the scene's features
/// and the traversal's register stack where the tree is shallow enough ([`bvh_defines`]).
pub(super) fn common_defines(ctx: &Context, scene: &Scene, bvh: &Bvh, tiled: bool) -> Defines {
    let mut common = crate::rng::defines(scene.integrator.sampler);
    common.push(("NO_QUEUE".into(), format!("{}u", scene_buffers::NO_QUEUE)));
    if ctx.features.subgroup_ballot {
        common.push(("SUBGROUP_QUEUES".into(), "1".into()));
    }
    if tiled {
        common.push(("TILED".into(), "1".into()));
    }
    // Without doubles, the triangle test misses the hits it cannot resolve in single
    // precision instead of redoing them in double (shaders/bvh.glsl, bvh_triangle_f64).
    if !ctx.features.shader_float64 {
        common.push(("BVH_NO_F64".into(), "1".into()));
    }
    common.extend(
        scene_features(scene)
            .into_iter()
            .map(|f| (f.to_string(), "1".to_string())),
    );
    common.extend(bvh_defines(bvh));
    common
}

/// `BVH_STACK_REGS`: the traversal stack in that many registers (`shaders/bvh.glsl`), for a
/// tree shallow enough ([`crate::bvh::register_stack_size`]); none for a deeper one, whose
/// traversal keeps the array stack.
pub fn bvh_defines(bvh: &Bvh) -> Vec<(String, String)> {
    crate::bvh::register_stack_size(bvh.stats.max_depth)
        .map(|n| ("BVH_STACK_REGS".to_string(), n.to_string()))
        .into_iter()
        .collect()
}

/// The defines of `brdf/any.glsl` for `models`: each model's `MODEL_<NAME>` (its index) and the
/// features its materials need.
fn any_model_defines(scene: &Scene, models: &[usize]) -> Defines {
    let mut defs = Defines::new();
    for &model in models {
        defs.push((model_define(MODELS[model].name), format!("{model}u")));
        defs.extend(
            model_features(scene, model)
                .into_iter()
                .map(|f| (f.to_string(), "1".to_string())),
        );
    }
    defs
}

/// The features (defines) `model` needs for the scene's materials.
fn model_features(scene: &Scene, model: usize) -> BTreeSet<&'static str> {
    let mut f = BTreeSet::new();
    for m in scene
        .materials
        .iter()
        .filter(|m| m.model == model && m.brdf.scatters())
    {
        f.extend(m.defines());
    }
    f
}

/// The kernels `integrator` needs and the order they run in: the wavefront stages (fused when
/// the scene shades one model: `extend_shade`), or the megakernel; both end in `accumulate`.
/// `integrator` is resolved ([`Integrator::resolve`]) by the caller; an unresolved `Auto`
/// builds the wavefront.
/// One shade pipeline per model of the scene (`Scene::shaded_models`). `common` are the
/// defines every kernel gets ([`common_defines`]).
pub(super) fn build_kernels<'a>(
    ctx: &'a Context,
    scene: &Scene,
    owned: &mut Owned<'a>,
    compiler: &ShaderCompiler,
    setup: &mut SetupStats,
    integrator: Integrator,
    common: Defines,
) -> Result<(Schedule, KernelId)> {
    let models = &scene.shaded_models()[..];
    let mut b = Builder {
        ctx,
        compiler,
        owned,
        setup,
        common,
        generated: vec![(interface::HEADER.to_string(), interface::glsl())],
        kinds: Binding::ALL.iter().map(|b| b.descriptor_type()).collect(),
    };
    let queue = |slot: usize, model: usize| ModelQueue {
        slot: slot as u32,
        model,
    };
    let schedule = match integrator {
        Integrator::Wavefront | Integrator::Auto => {
            let base = WaveKernels {
                generate: b.stage(Stage::Generate)?,
                prepare: b.stage(Stage::Prepare)?,
            };
            if let (false, [model]) = (separate_stages(integrator, models.len()), models) {
                // One shaded model: extend shades in place and traces the shadow ray
                // (extend_shade.comp); the material and shadow queues would only cost.
                let kernel = b.model_stage(Stage::ExtendShade, scene, *model)?;
                Schedule::Fused {
                    base,
                    extend_shade: ShadeKernel {
                        queue: queue(0, *model),
                        kernel,
                    },
                }
            } else {
                let shadow = b.stage(Stage::Shadow)?;
                let extend = b.stage(Stage::Extend)?;
                let mut shade = Vec::new();
                for (slot, &model) in models.iter().enumerate() {
                    let kernel = b.model_stage(Stage::Shade, scene, model)?;
                    shade.push(ShadeKernel {
                        queue: queue(slot, model),
                        kernel,
                    });
                }
                Schedule::Wavefront {
                    base,
                    extend,
                    shade,
                    shadow,
                }
            }
        }
        Integrator::Megakernel => {
            let defs = any_model_defines(scene, models);
            let kernel = b.build(Stage::Megakernel, Stage::Megakernel.name(), defs, vec![])?;
            // The shade stages' non-finite counters are read per model: the megakernel counts
            // at the same slots.
            let models = models.iter().enumerate().map(|(s, &m)| queue(s, m));
            Schedule::Megakernel {
                kernel,
                models: models.collect(),
            }
        }
    };
    let accumulate = b.stage(Stage::Accumulate)?;
    Ok((schedule, accumulate))
}

/// The `#define`s that compile in only what the scene has: the primitive kinds (BVH_TRIANGLES,
/// BVH_SPHERES), the kinds of light-table entries (LIGHT_TRIANGLES, LIGHT_TRIANGLE_PAIRS,
/// LIGHT_SPHERES: src/lights.rs), per-vertex shading normals
/// and texture coordinates (SCENE_SHADING_NORMALS, SCENE_UVS), point and directional lights
/// (SCENE_DELTA_LIGHTS), two-sided materials (SCENE_TWOSIDED), Russian roulette
/// (RUSSIAN_ROULETTE), hidden emitters (HIDE_EMITTERS), an environment map (SCENE_ENV_MAP), textured materials
/// (SCENE_TEXTURES), images (SCENE_IMAGES: the map or textures), a thin-lens camera
/// (CAMERA_THIN_LENS). On lavapipe both sides of every branch run for all lanes, so code for
/// something the scene lacks is not free.
pub fn scene_features(scene: &Scene) -> Vec<&'static str> {
    let mut f = Vec::new();
    if !scene.triangles.is_empty() || scene.spheres.is_empty() {
        f.push("BVH_TRIANGLES");
    }
    if !scene.spheres.is_empty() {
        f.push("BVH_SPHERES");
    }
    let (single, pairs, spheres) = crate::lights::LightTable::build(scene).area_kinds();
    if single || !(pairs || spheres) {
        f.push("LIGHT_TRIANGLES");
    }
    if pairs {
        f.push("LIGHT_TRIANGLE_PAIRS");
    }
    if spheres {
        f.push("LIGHT_SPHERES");
    }
    if scene.has_shading_normals() {
        f.push("SCENE_SHADING_NORMALS");
    }
    if scene.has_uvs() {
        f.push("SCENE_UVS");
    }
    if !scene.lights.is_empty() {
        f.push("SCENE_DELTA_LIGHTS");
    }
    if scene.materials.iter().any(|m| m.twosided) {
        f.push("SCENE_TWOSIDED");
    }
    if scene.integrator.russian_roulette {
        f.push("RUSSIAN_ROULETTE");
    }
    if scene.integrator.hide_emitters {
        f.push("HIDE_EMITTERS");
    }
    if scene.environment_map.is_some() {
        f.push("SCENE_ENV_MAP");
    }
    let textured = scene.materials.iter().any(|m| !m.textures.is_empty());
    if textured {
        f.push("SCENE_TEXTURES");
    }
    if scene.environment_map.is_some() || textured {
        f.push("SCENE_IMAGES");
    }
    if scene.camera.aperture_radius > 0.0 {
        f.push("CAMERA_THIN_LENS");
    }
    f
}

/// How a shader is compiled for one model (the shade pipelines and the BRDF probe): the virtual
/// include "brdf/model.glsl" is the model's file, BRDF_EVAL / BRDF_PDF / BRDF_SAMPLE name its
/// functions, and `features` (the materials' `defines`) are defined as 1. Returns the defines
/// and the include overrides.
pub(crate) fn model_shader_inputs<'f>(
    model: usize,
    features: impl IntoIterator<Item = &'f str>,
) -> (Defines, Defines) {
    let name = MODELS[model].name;
    let mut defines: Vec<(String, String)> = features
        .into_iter()
        .map(|d| (d.to_string(), "1".to_string()))
        .collect();
    defines.push(("BRDF_EVAL".into(), format!("{name}_eval")));
    defines.push(("BRDF_PDF".into(), format!("{name}_pdf")));
    defines.push(("BRDF_SAMPLE".into(), format!("{name}_sample")));
    defines.push(("BRDF_TEXTURED".into(), format!("{name}_textured")));
    let overrides = vec![("brdf/model.glsl".to_string(), format!("brdf/{name}.glsl"))];
    (defines, overrides)
}

#[cfg(test)]
mod tests {
    use super::scene_features;

    /// Only what a scene has is compiled in: the Cornell box has lit triangles and nothing
    /// else; the lineup adds spheres; the OBJ example has per-vertex normals.
    #[test]
    fn scene_features_follow_the_scene() {
        let load = |name: &str| {
            crate::scene::load(
                &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("scenes")
                    .join(name),
            )
            .unwrap()
        };
        assert_eq!(
            scene_features(&load("cornell-box.toml")),
            ["BVH_TRIANGLES", "LIGHT_TRIANGLE_PAIRS"],
            "the light quad is one pair of triangles"
        );
        let lineup = scene_features(&load("lineup.toml"));
        assert!(lineup.contains(&"BVH_SPHERES"), "{lineup:?}");
        let mut rr = load("cornell-box.toml");
        rr.integrator.russian_roulette = true;
        assert!(scene_features(&rr).contains(&"RUSSIAN_ROULETTE"));
        let mut none = load("cornell-box.toml");
        none.triangles.clear();
        assert!(
            scene_features(&none).contains(&"BVH_TRIANGLES"),
            "an empty scene still compiles"
        );
    }
}
