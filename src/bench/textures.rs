//! What textures cost: for a bench scene with textured materials, the speed of the scene
//! against the same scene with each textured parameter a constant (its texture's mean), on the
//! GPU (wavefront) and on the CPU reference. bench.md gets the table.

use super::{load_scene, BenchOptions};
use crate::brdf::textured::ParamValues;
use crate::bvh;
use crate::film::Tile;
use crate::render::{self, RenderRequest};
use crate::scene::Scene;
use crate::vk::{Context, ContextOptions, ShaderCompiler};
use anyhow::Result;
use glam::Vec3;
use std::fmt::Write as _;
use std::time::Instant;

/// The scene with every textured parameter replaced by its texture's mean value: the same
/// geometry (texture coordinates included), lights and settings.
pub fn constant_parameters(s: &Scene) -> Scene {
    let mut c = s.clone();
    for m in &mut c.materials {
        if m.textures.is_empty() {
            continue;
        }
        let values = ParamValues {
            values: m
                .textures
                .iter()
                .map(|t| {
                    let n = t.texture.texels.len().max(1) as f64;
                    let sum = t.texture.texels.iter().fold([0.0f64; 3], |a, x| {
                        [a[0] + x[0] as f64, a[1] + x[1] as f64, a[2] + x[2] as f64]
                    });
                    let mean = Vec3::new(
                        (sum[0] / n) as f32,
                        (sum[1] / n) as f32,
                        (sum[2] / n) as f32,
                    );
                    (t.param.name, mean)
                })
                .collect(),
        };
        m.brdf = m.brdf.with_params(&values);
        m.textures.clear();
    }
    c
}

/// The table of bench.md's "Textures" section, or `None` for a scene without textures. Each
/// scene renders 4 samples per pixel twice on each backend (the first warms the pipelines and
/// caches), alternating textured and constant; the faster of the two timed passes counts.
pub(super) fn texture_cost(o: &BenchOptions) -> Result<Option<String>> {
    let mut textured = load_scene(o)?;
    if textured.materials.iter().all(|m| m.textures.is_empty()) {
        return Ok(None);
    }
    textured.integrator.spp = 4;
    let constant = constant_parameters(&textured);
    let ctx = Context::new(&ContextOptions {
        device: o.device.clone(),
        validation: false,
        ray_query: false,
    })?;
    let compiler = ShaderCompiler::new()?;
    let paths = textured.width as f64 * textured.height as f64 * 4.0;
    let mut best = [[f64::INFINITY; 2]; 2];
    for _round in 0..3 {
        for (k, s) in [&textured, &constant].into_iter().enumerate() {
            eprintln!("textures: {}", ["textured", "constant parameters"][k]);
            let tree = std::sync::Arc::new(bvh::build(s));
            let full = Tile::full(s.width, s.height);
            let mut r = render::open(render::Backend::gpu(&ctx, &compiler), s, tree.clone(), full)?;
            let t = Instant::now();
            r.render(&RenderRequest::samples(0..4), &|_| {})?;
            best[0][k] = best[0][k].min(t.elapsed().as_secs_f64());
            drop(r);
            let t = Instant::now();
            render::render_all(render::Backend::Cpu, s, tree)?;
            best[1][k] = best[1][k].min(t.elapsed().as_secs_f64());
        }
    }
    let mut md = String::from(
        "| backend | textured paths/s | constant parameters paths/s | textured time / constant time |\n|---|---|---|---|\n",
    );
    for (name, b) in ["wavefront (GPU)", "CPU reference"].iter().zip(best) {
        let _ = writeln!(
            md,
            "| {name} | {:.3} M | {:.3} M | {:.2} |",
            paths / b[0] / 1e6,
            paths / b[1] / 1e6,
            b[0] / b[1]
        );
    }
    Ok(Some(md))
}
