//! What a probe kernel needs to trace rays through `shaders/bvh.glsl` outside the renderer:
//! its bindings (the rays, the results, then the tree and the scene as the renderer binds
//! them), its generated interface, and the scene's BVH uploaded into texel buffers as the
//! renderer uploads it. The traversal benchmark (`crate::bench::rays`) and the GLSL twin's
//! test (`tests/bvh_glsl.rs`) both trace through it.

use crate::bvh::Bvh;
use crate::gpu::interface::{self, ProbeBinding};
use crate::gpu::layout::{Binding, Kind};
use crate::gpu::scene_buffers;
use crate::scene::Scene;
use crate::vk::{Buffer, Context, Resource};
use anyhow::{bail, Result};
use ash::vk;

/// The path a probe kernel includes for [`interface_glsl`]'s text.
pub const INTERFACE_PATH: &str = "bvh_probe/interface.glsl";

/// The probe's bindings in slot order: `vec4 rays[]` (readonly), `uvec4 outp[]` (writeonly),
/// then the scene as the renderer binds it ([`interface::BVH_BINDINGS`]).
pub fn bindings() -> Vec<ProbeBinding> {
    let own = |block, member, access| ProbeBinding::Storage {
        block,
        member,
        access,
        about: "",
    };
    let mut b = vec![
        own("Rays", "vec4 rays[]", "readonly"),
        own("Out", "uvec4 outp[]", "writeonly"),
    ];
    b.extend(interface::BVH_BINDINGS.map(ProbeBinding::Layout));
    b
}

/// The generated interface of [`bindings`], with `uint count` as the push constant; to be
/// given to the shader compiler as the generated file [`INTERFACE_PATH`].
pub fn interface_glsl() -> String {
    let push = [interface::Field {
        name: "count",
        glsl: "uint",
        doc: "",
    }];
    interface::probe_glsl("BVH_PROBE_INTERFACE", &bindings(), &push)
}

/// The descriptor types of [`bindings`], for the pipeline.
pub fn descriptor_types() -> Vec<vk::DescriptorType> {
    bindings().iter().map(|b| b.descriptor_type()).collect()
}

/// The scene's BVH bindings ([`interface::BVH_BINDINGS`], in that order) uploaded as the
/// renderer uploads them: one buffer and one texel view each.
pub struct BvhTexels {
    buffers: Vec<Buffer>,
    views: Vec<vk::BufferView>,
}

impl BvhTexels {
    pub fn upload(ctx: &Context, scene: &Scene, bvh: &Bvh) -> Result<BvhTexels> {
        let mut t = BvhTexels {
            buffers: Vec::new(),
            views: Vec::new(),
        };
        for binding in interface::BVH_BINDINGS {
            let bytes = match binding {
                Binding::BvhNodes => scene_buffers::bvh_nodes(bvh).to_vec(),
                Binding::BvhPrims => bytemuck::cast_slice(&bvh.prims).to_vec(),
                Binding::Triangles => {
                    bytemuck::cast_slice(&scene_buffers::triangle_data(scene)).to_vec()
                }
                Binding::Spheres => {
                    bytemuck::cast_slice(&scene_buffers::sphere_data(scene)).to_vec()
                }
                other => bail!("{other:?} is not one of the BVH bindings"),
            };
            let Kind::ReadImage(format) = binding.kind() else {
                bail!("{binding:?} is not a texel buffer in the renderer");
            };
            // On an error, what was made so far is destroyed by the context's teardown.
            let buf = ctx.create_buffer_with_data(binding.name(), &bytes, binding.usage())?;
            t.views.push(ctx.create_buffer_view(&buf, format)?);
            t.buffers.push(buf);
        }
        Ok(t)
    }

    /// The resources of the BVH bindings, after the probe's own two.
    pub fn resources(&self) -> impl Iterator<Item = Resource<'_>> {
        self.buffers
            .iter()
            .zip(&self.views)
            .map(|(b, &v)| Resource::Texels(b, v))
    }

    pub fn destroy(self, ctx: &Context) {
        for v in self.views {
            ctx.destroy_buffer_view(v);
        }
        for b in self.buffers {
            ctx.destroy_buffer(b);
        }
    }
}
