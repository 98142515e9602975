//! Set-up and speed against scene size (`--scaling`), and the generated sphere mesh.

use super::{load_scene, BenchOptions};
use crate::bvh;
use crate::film::Tile;
use crate::render::{self, RenderRequest, Renderer};
use crate::scene::{self, Scene, Triangle};
use crate::vk::{Context, ContextOptions, ShaderCompiler};
use anyhow::Result;
use glam::Vec3;
use std::fmt::Write as _;
use std::time::Instant;

/// Set-up and speed against scene size: the bench scene, the Cornell box with a tessellated
/// sphere of about `mesh_triangles` triangles added, and the lineup scene beside the bench
/// scene if there is one. Each: BVH build, shader compile cold (empty cache) and warm, pipeline
/// creation, and a short wavefront and CPU render.
pub(super) fn scaling(o: &BenchOptions, mesh_triangles: u32) -> Result<String> {
    let base = load_scene(o)?;
    let mut scenes: Vec<(String, Scene)> = vec![(o.scene.display().to_string(), base.clone())];
    let mut big = base.clone();
    add_sphere_mesh(&mut big, mesh_triangles);
    scenes.push((format!("{} + sphere mesh", o.scene.display()), big));
    if let Some(lineup) = o
        .scene
        .parent()
        .map(|d| d.join("lineup.toml"))
        .filter(|p| p.exists() && *p != o.scene)
    {
        let mut s = scene::load(&lineup)?;
        s.width = base.width;
        s.height = base.height;
        scenes.push((lineup.display().to_string(), s));
    }
    let ctx = Context::new(&ContextOptions {
        device: o.device.clone(),
        validation: false,
        ray_query: false,
    })?;
    let mut md = String::from("| scene | triangles | BVH nodes | BVH build s | compile cold s | compile warm s | pipelines s | wavefront paths/s | rays/s | CPU paths/s |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for (name, mut s) in scenes {
        eprintln!("scaling: {name}");
        s.integrator.spp = 4;
        let t = Instant::now();
        let bvh = std::sync::Arc::new(bvh::build(&s));
        let t_bvh = t.elapsed().as_secs_f64();
        let cold_dir = tempfile::tempdir()?;
        let cold = ShaderCompiler::new()?.with_cache_dir(cold_dir.path());
        let full = Tile::full(s.width, s.height);
        let setup = |r: &dyn Renderer| r.describe().gpu.map(|g| g.setup).unwrap_or_default();
        let r = render::open(render::Backend::gpu(&ctx, &cold), &s, bvh.clone(), full)?;
        let compile_cold = setup(r.as_ref()).seconds_shader_compile;
        drop(r);
        let mut r = render::open(render::Backend::gpu(&ctx, &cold), &s, bvh.clone(), full)?;
        let warm = setup(r.as_ref());
        let (compile_warm, create) = (warm.seconds_shader_compile, warm.seconds_pipeline_create);
        let t = Instant::now();
        let out = r
            .render(&RenderRequest::samples(0..s.integrator.spp), &|_| {})?
            .output;
        let dt = t.elapsed().as_secs_f64();
        let paths = s.width as f64 * s.height as f64 * s.integrator.spp as f64;
        drop(r);
        let t = Instant::now();
        render::render_all(render::Backend::Cpu, &s, bvh.clone())?;
        let dt_cpu = t.elapsed().as_secs_f64();
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {t_bvh:.3} | {compile_cold:.3} | {compile_warm:.3} | {create:.3} | {:.3} M | {:.3} M | {:.3} M |",
            s.triangles.len(),
            bvh.nodes.len(),
            paths / dt / 1e6,
            (out.extension_rays + out.shadow_rays) as f64 / dt / 1e6,
            paths / dt_cpu / 1e6
        );
    }
    Ok(md)
}

/// Adds a UV sphere of about `n` triangles (white Lambert, the scene's first material) in the
/// middle of the scene's bounds, a third of their smallest extent across.
pub fn add_sphere_mesh(s: &mut Scene, n: u32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for t in &s.triangles {
        for v in t.v {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if lo.x > hi.x {
        (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    }
    let center = 0.5 * (lo + hi);
    let radius = (hi - lo).min_element() / 6.0;
    // rings × segments × 2 triangles ≈ n, with segments = 2 rings.
    let rings = ((n as f64 / 4.0).sqrt().ceil() as u32).max(2);
    let segs = 2 * rings;
    let p = |i: u32, j: u32| -> Vec3 {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
        center
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
    };
    let material = 0;
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            // Outward winding: cross(b - a, c - a) points away from the centre.
            for v in [[a, d, c], [a, c, b]] {
                let t = Triangle {
                    v,
                    material,
                    emitter: None,
                };
                if t.area() > 0.0 {
                    s.triangles.push(t);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    #[test]
    fn sphere_mesh_has_about_n_outward_triangles() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut s = scene::load(&path).unwrap();
        let before = s.triangles.len();
        let (lo, hi) = s.triangles.iter().flat_map(|t| t.v).fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), v| (lo.min(v), hi.max(v)),
        );
        add_sphere_mesh(&mut s, 10_000);
        let n = s.triangles.len() - before;
        assert!((9_000..=11_000).contains(&n), "{n}");
        let c = 0.5 * (lo + hi);
        for t in &s.triangles[before..] {
            let mid = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
            assert!(t.geometric_normal_unnormalized().dot(mid - c) > 0.0);
        }
    }
}
