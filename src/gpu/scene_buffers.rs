//! Packing the scene into the GPU buffers the kernels read (layouts documented beside each
//! binding in `gpu::layout`, from which the kernels' declarations are generated).

use super::interface::Globals;
use crate::brdf::{Material, RECORD_WORDS};
use crate::bvh::Bvh;
use crate::camera::CameraBasis;
use crate::lights::LightTable;
use crate::scene::Scene;

pub const NO_EMITTER: u32 = u32::MAX;
/// Material header value for a surface that does not scatter: paths end there.
pub const NO_QUEUE: u32 = u32::MAX;

fn bits(x: u32) -> f32 {
    f32::from_bits(x)
}

/// Texels per triangle in the triangle buffer ([`write_triangle_data`]).
pub const TRIANGLE_TEXELS: usize = 3;

/// 3 vec4 per triangle: (v0, material), (v1, emitter), (v2, 0).
pub fn triangle_data(scene: &Scene) -> Vec<[f32; 4]> {
    let mut out = vec![[0.0; 4]; scene.triangles.len() * TRIANGLE_TEXELS];
    write_triangle_data(scene, &mut out);
    out
}

/// [`triangle_data`] written into `out` (`TRIANGLE_TEXELS` texels a triangle), such as a
/// buffer's mapped memory: a million triangles' 48 MB then have no copy on the host.
pub fn write_triangle_data(scene: &Scene, out: &mut [[f32; 4]]) {
    use rayon::prelude::*;
    out.par_chunks_mut(TRIANGLE_TEXELS)
        .zip(&scene.triangles)
        .for_each(|(o, t)| {
            let e = t.emitter.unwrap_or(NO_EMITTER);
            o[0] = [t.v[0].x, t.v[0].y, t.v[0].z, bits(t.material)];
            o[1] = [t.v[1].x, t.v[1].y, t.v[1].z, bits(e)];
            o[2] = [t.v[2].x, t.v[2].y, t.v[2].z, 0.0];
        });
}

/// 4 vec4 per triangle: (n0, u0), (n1, u1), (n2, u2), (v0, v1, v2, flags: 1 normals, 2 uvs).
/// When no triangle has shading normals or texture coordinates, one zero texel: the kernels
/// then never read the buffer (neither SCENE_SHADING_NORMALS nor SCENE_UVS is defined,
/// `kernels::scene_features`), and a buffer cannot be empty. That spares a million-triangle
/// mesh without them 64 MB.
pub fn triangle_attributes(scene: &Scene) -> Vec<[f32; 4]> {
    if !(scene.has_shading_normals() || scene.has_uvs()) {
        return vec![[0.0; 4]];
    }
    let mut out = Vec::with_capacity(scene.triangles.len() * 4);
    for i in 0..scene.triangles.len() {
        let a = scene.attributes_of(i);
        let n = a.n.unwrap_or([glam::Vec3::ZERO; 3]);
        let uv = a.uv.unwrap_or([glam::Vec2::ZERO; 3]);
        let flags = (a.n.is_some() as u32) | ((a.uv.is_some() as u32) << 1);
        for k in 0..3 {
            out.push([n[k].x, n[k].y, n[k].z, uv[k].x]);
        }
        out.push([uv[0].y, uv[1].y, uv[2].y, bits(flags)]);
    }
    out
}

/// Texels (vec4) per sphere in [`sphere_data`] (GLSL twin: `SPHERE_TEXELS`, bvh.glsl).
pub const SPHERE_TEXELS: usize = 3;

/// [`SPHERE_TEXELS`] vec4 per sphere: (center, radius), (material, emitter, inward, frame
/// flags: 1 turned, 2 mirrored), the frame's quaternion (x, y, z, w)
/// (`crate::scene::SphereFrame`).
pub fn sphere_data(scene: &Scene) -> Vec<[f32; 4]> {
    let mut out = Vec::with_capacity(scene.spheres.len() * SPHERE_TEXELS);
    for s in &scene.spheres {
        out.push([s.center.x, s.center.y, s.center.z, s.radius]);
        let flags = s.frame.map_or(0, |f| 1 | (f.mirror as u32) << 1);
        out.push([
            bits(s.material),
            bits(s.emitter.unwrap_or(NO_EMITTER)),
            bits(s.inward as u32),
            bits(flags),
        ]);
        out.push(s.frame.map_or([0.0, 0.0, 0.0, 1.0], |f| f.q));
    }
    out
}

/// Each material's queue: the position of its model among the scene's shaded models
/// (`Scene::shaded_models`, one material queue and shade pipeline each), or [`NO_QUEUE`] for a
/// material that does not scatter.
pub fn queue_slots(scene: &Scene) -> Vec<u32> {
    let models = scene.shaded_models();
    scene
        .materials
        .iter()
        .map(|m| match m.brdf.scatters() {
            true => models.iter().position(|&x| x == m.model).unwrap() as u32,
            false => NO_QUEUE,
        })
        .collect()
}

/// Material records; `queue_slot[m]` is the material's queue (or NO_QUEUE). A textured
/// material's header.w is its list in the texture table ([`TextureTable`]), 0 for none.
pub fn material_records(scene: &Scene, queue_slot: &[u32]) -> Vec<[u32; RECORD_WORDS]> {
    let mut r = records(&scene.materials, queue_slot);
    let table = TextureTable::of(scene);
    for (rec, list) in r.iter_mut().zip(&table.lists) {
        rec[3] = *list;
    }
    r
}

/// The scene's textures as the GPU reads them (`shaders/texture.glsl`): the texels, which
/// follow the environment map's in binding `images`, and binding `tex_info`: texel 0 unused,
/// then three texels per distinct texture, (first texel, width, height, filter | wrap << 4) and
/// the two rows of its `to_uv` as float bits, then each textured material's list: (count) and
/// per textured parameter (texture, record word, slot mode). A parameter whose value the
/// record does not hold (no slot) is left out.
pub struct TextureTable {
    pub texels: Vec<[f32; 4]>,
    pub info: Vec<[u32; 4]>,
    /// Per material, its list in `info` (0: no textures).
    pub lists: Vec<u32>,
}

impl TextureTable {
    pub fn of(scene: &Scene) -> TextureTable {
        use std::sync::Arc;
        let base = scene.environment_map.as_ref().map_or(0, |m| m.texels.len()) as u32;
        // The distinct textures, in the order the materials first name them.
        let mut textures: Vec<&Arc<crate::texture::Texture>> = Vec::new();
        let mut body: Vec<[u32; 4]> = Vec::new();
        let mut offsets: Vec<Option<u32>> = Vec::new();
        for m in &scene.materials {
            let mut bound = Vec::new();
            for t in &m.textures {
                let Some(slot) = t.slot else { continue };
                let k = match textures.iter().position(|x| Arc::ptr_eq(x, &t.texture)) {
                    Some(k) => k,
                    None => {
                        textures.push(&t.texture);
                        textures.len() - 1
                    }
                };
                bound.push([k as u32, slot.word, slot.mode as u32, 0]);
            }
            if bound.is_empty() {
                offsets.push(None);
                continue;
            }
            offsets.push(Some(body.len() as u32));
            body.push([bound.len() as u32, 0, 0, 0]);
            body.extend(bound);
        }
        let mut texels = Vec::new();
        let mut info = vec![[0u32; 4]];
        for t in &textures {
            let first = base + texels.len() as u32;
            let flags = t.filter as u32 | (t.wrap as u32) << 4;
            info.push([first, t.width, t.height, flags]);
            for row in t.to_uv {
                info.push([row[0].to_bits(), row[1].to_bits(), row[2].to_bits(), 0]);
            }
            texels.extend(t.texels.iter().map(|c| [c[0], c[1], c[2], 0.0]));
        }
        let start = info.len() as u32;
        let lists = offsets.iter().map(|o| o.map_or(0, |o| start + o)).collect();
        info.extend(body);
        TextureTable {
            texels,
            info,
            lists,
        }
    }
}

/// Records of materials outside a scene (queue slot 0).
pub fn material_records_of(materials: &[Material]) -> Vec<[u32; RECORD_WORDS]> {
    records(materials, &vec![0; materials.len()])
}

fn records(materials: &[Material], queue_slot: &[u32]) -> Vec<[u32; RECORD_WORDS]> {
    let tables = MeasuredTables::of(materials);
    materials
        .iter()
        .zip(queue_slot)
        .zip(&tables.first_texel)
        .map(|((m, &slot), first)| {
            let mut r = [0u32; RECORD_WORDS];
            r[0] = m.model as u32;
            r[1] = slot;
            r[2] = m.twosided as u32;
            for (k, p) in m.brdf.pack().0.iter().enumerate() {
                r[4 + k] = p.to_bits();
            }
            // A measured material's p[0].x: its table's first texel (src/brdf/measured.rs).
            if let Some(t) = first {
                r[4] = *t;
            }
            r
        })
        .collect()
}

/// The distinct measured tables of a set of materials, each uploaded once: materials naming
/// the same file share its table (`brdf::measured::load_shared`), and a table is told apart by
/// its canonical path.
pub struct MeasuredTables {
    /// The tables in the order the materials first name them.
    pub tables: Vec<std::sync::Arc<crate::brdf::measured::Shared>>,
    /// Per material, the first texel of its table in [`MeasuredTables::texels`] (measured
    /// materials only).
    pub first_texel: Vec<Option<u32>>,
}

impl MeasuredTables {
    pub fn of(materials: &[Material]) -> MeasuredTables {
        let mut tables: Vec<std::sync::Arc<crate::brdf::measured::Shared>> = Vec::new();
        let first_texel = materials
            .iter()
            .map(|m| {
                let shared = &m.brdf.measured()?.shared;
                let k = match tables.iter().position(|t| t.path == shared.path) {
                    Some(k) => k,
                    None => {
                        tables.push(shared.clone());
                        tables.len() - 1
                    }
                };
                Some((k * crate::measured::merl::CELLS) as u32)
            })
            .collect();
        MeasuredTables {
            tables,
            first_texel,
        }
    }

    /// One RGBA texel per cell of each table, (red, green, blue, 0), in the file's cell order;
    /// a single zero texel when there is no table (a buffer cannot be empty).
    pub fn texels(&self) -> Vec<[f32; 4]> {
        use crate::measured::merl::CELLS;
        let mut out = Vec::with_capacity((self.tables.len() * CELLS).max(1));
        for t in &self.tables {
            let v = t.table.values();
            out.extend((0..CELLS).map(|i| [v[i], v[CELLS + i], v[2 * CELLS + i], 0.0]));
        }
        if out.is_empty() {
            out.push([0.0; 4]);
        }
        out
    }

    /// Bytes the tables take on the GPU (0 without measured materials).
    pub fn gpu_bytes(&self) -> u64 {
        (self.tables.len() * crate::measured::merl::CELLS * 16) as u64
    }
}

pub fn light_data(lights: &LightTable) -> Vec<[u32; 2]> {
    lights
        .prims
        .iter()
        .zip(&lights.cdf)
        .map(|(&p, &c)| [p, c.to_bits()])
        .collect()
}

/// One texel per emitter, (radiance, lum(Le)/W); then two per delta light
/// ([`LightTable::delta`]): (position or direction to the light, 1 if directional else 0) and
/// (intensity or irradiance, selection probability).
pub fn emitter_data(scene: &Scene, lights: &LightTable) -> Vec<[f32; 4]> {
    let mut data: Vec<[f32; 4]> = scene
        .emitters
        .iter()
        .zip(&lights.select_density)
        .map(|(e, d)| [e.radiance.x, e.radiance.y, e.radiance.z, *d])
        .collect();
    for l in &lights.delta {
        let kind = if l.directional { 1.0 } else { 0.0 };
        data.push([l.v.x, l.v.y, l.v.z, kind]);
        data.push([l.value.x, l.value.y, l.value.z, l.select_prob]);
    }
    data
}

/// The scene-wide values the kernels read (`Globals`, declared once in `gpu::interface`).
pub fn globals(
    scene: &Scene,
    lights: &LightTable,
    num_queues: u32,
    wave_paths: u32,
    tile: crate::film::Tile,
) -> Globals {
    let cam = CameraBasis::new(scene);
    let it = &scene.integrator;
    let env = scene.environment_map.as_deref();
    let [env_x, env_y, env_z] = env.map_or([glam::Vec3::ZERO; 3], |m| m.to_local_rows());
    Globals {
        cam_origin: cam.origin.to_array(),
        cam_forward: cam.forward.to_array(),
        cam_right: cam.right.to_array(),
        cam_up: cam.up.to_array(),
        environment: scene.environment.to_array(),
        num_lights: lights.prims.len() as u32,
        width: scene.width,
        height: scene.height,
        max_depth: it.max_depth,
        seed: it.seed,
        rr_enabled: it.russian_roulette as u32,
        rr_start_depth: it.rr_start_depth,
        num_queues,
        wave_paths,
        tile_x: tile.x,
        tile_y: tile.y,
        tile_width: tile.width,
        pattern_bits: it.pattern_bits(),
        env_x: env_x.to_array(),
        env_y: env_y.to_array(),
        env_z: env_z.to_array(),
        env_width: env.map_or(0, |m| m.width),
        env_height: env.map_or(0, |m| m.height),
        env_select: lights.env_select,
        lens_right: cam.lens_right.to_array(),
        lens_up: cam.lens_up.to_array(),
        focus_distance: cam.focus_distance,
    }
}

/// The texels of binding `images`: the environment map's radiance (r, g, b, 0), row by row,
/// then the textures'; one zero texel for a scene without images (a buffer cannot be empty).
pub fn image_texels(scene: &Scene) -> Vec<[f32; 4]> {
    let mut out = Vec::new();
    if let Some(m) = &scene.environment_map {
        out.extend(m.texels.iter().map(|t| [t[0], t[1], t[2], 0.0]));
    }
    out.extend(TextureTable::of(scene).texels);
    if out.is_empty() {
        out.push([0.0; 4]);
    }
    out
}

/// Binding `env_dist`: the environment map's marginal CDF, then its rows' conditional CDFs,
/// then its cells' densities (`crate::envmap::EnvMap`); one zero without a map.
pub fn env_dist(scene: &Scene) -> Vec<f32> {
    match &scene.environment_map {
        Some(m) => m
            .marginal
            .iter()
            .chain(&m.conditional)
            .chain(&m.cell_pdf)
            .copied()
            .collect(),
        None => vec![0.0],
    }
}

/// BVH nodes as raw words (4 vec4 each).
pub fn bvh_nodes(bvh: &Bvh) -> &[u8] {
    bytemuck::cast_slice(&bvh.nodes)
}
