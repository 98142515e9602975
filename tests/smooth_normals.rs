//! Shading normals create no energy: a white furnace (a grey Lambertian icosphere with smooth
//! vertex normals under a uniform environment of radiance 1) returns at most its albedo in
//! every pixel, on both backends, and nearly all of it; the two backends agree with the same
//! seed. The geometric normal decides the side: a light or BSDF direction below the geometric
//! surface is dropped, and a view direction below the shading hemisphere reflects nothing.

mod common;
use brdfwave::metrics;
use brdfwave::scene::ply::{write, Format, PlyMesh};
use brdfwave::scene::{load, shapes::icosphere};
use common::*;
use glam::Vec3;

const ALBEDO: f32 = 0.8;

#[test]
fn a_white_furnace_with_smooth_normals_returns_at_most_its_albedo() {
    let (positions, tris) = icosphere(2, Vec3::ZERO, 1.0);
    let mesh = PlyMesh {
        normals: Some(positions.iter().map(|p| p.normalize()).collect()),
        positions,
        uvs: None,
        faces: tris.iter().map(|t| t.map(|i| i as u32).to_vec()).collect(),
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("ico.ply"),
        write(&mesh, Format::BinaryLittleEndian),
    )
    .unwrap();
    let scene = format!(
        "[camera]\nposition = [0, 0, 3.2]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 24\n\
         height = 24\n[integrator]\nspp = 8\nmax_depth = 6\nseed = 9\n[environment]\nradiance = 1\n\
         [materials.grey]\nmodel = \"lambert\"\nalbedo = {ALBEDO}\n\
         [[shapes]]\nmaterial = \"grey\"\nply = \"ico.ply\"\n"
    );
    std::fs::write(dir.path().join("furnace.toml"), scene).unwrap();
    let s = load(&dir.path().join("furnace.toml")).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!((0..s.triangles.len()).all(|i| s.attributes_of(i).n.is_some()));

    let ctx = context();
    let (gpu, pipelines) = render_gpu(&ctx, &s);
    finish(ctx);
    let cpu = render_cpu(&s);
    println!("{pipelines:?}");
    let agree = metrics::fraction_within(&gpu.mean, &cpu.mean, 1e-4, 1e-5).unwrap();
    assert!(agree.channel_fraction >= 0.99, "GPU vs CPU: {agree}");
    for (name, r) in [("gpu", &gpu), ("cpu", &cpu)] {
        assert_eq!(r.nonfinite_samples, 0, "{name}");
        let (mut sphere, mut sum, mut lowest) = (0usize, 0.0f64, f32::MAX);
        for y in 0..s.height {
            for x in 0..s.width {
                let v = r.mean.get(x, y);
                for c in v {
                    // No energy gain anywhere: the environment (1) or at most the albedo.
                    assert!(c <= 1.0 + 1e-6, "{name}: pixel ({x}, {y}) = {v:?}");
                }
                // Pixels wholly on the sphere (well inside its silhouette of radius ~0.9 of
                // the half-height) see only the sphere: at most the albedo.
                let (px, py) = (x as f32 + 0.5 - 12.0, y as f32 + 0.5 - 12.0);
                if (px * px + py * py).sqrt() < 7.0 {
                    sphere += 1;
                    for c in v {
                        assert!(
                            c <= ALBEDO * (1.0 + 1e-6),
                            "{name}: pixel ({x}, {y}) = {v:?} > albedo"
                        );
                        lowest = lowest.min(c);
                        sum += c as f64;
                    }
                }
            }
        }
        let mean = sum / (3 * sphere) as f64;
        println!("{name}: {sphere} pixels on the sphere, mean {mean:.6}, lowest {lowest:.6} (albedo {ALBEDO})");
        // The energy lost to directions below the geometric surface is small.
        assert!(
            mean >= ALBEDO as f64 * 0.995,
            "{name}: mean {mean} of albedo {ALBEDO}"
        );
    }
}
