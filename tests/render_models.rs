//! Image-level GPU-vs-CPU comparison of the scenes that use the survey's models (same seed:
//! the two renderers follow the same paths), and the scenes' pipeline sets.

mod common;
use common::*;

fn same_seed_parity(name: &str, w: u32, h: u32, spp: u32, depth: u32) -> Vec<String> {
    common::same_seed_parity(
        &scene(name, w, h, spp, depth, 11),
        name.trim_end_matches(".toml"),
    )
}

#[test]
fn lineup_gpu_matches_cpu_and_builds_one_shade_pipeline_per_model() {
    let pipelines = same_seed_parity("lineup.toml", 160, 50, 4, 5);
    let mut shade: Vec<&str> = pipelines
        .iter()
        .filter_map(|p| p.strip_prefix("shade_"))
        .collect();
    shade.sort();
    // Every analytic model: a measured table cannot be shipped, and tests/brdf_measured.rs
    // renders `brdf fit`'s lineup, which shows the measured material beside its fits.
    let mut every: Vec<&str> = brdfwave::brdf::MODELS
        .iter()
        .filter(|m| {
            !m.params
                .iter()
                .any(|p| p.kind == brdfwave::brdf::Kind::File)
        })
        .map(|m| m.name)
        .collect();
    every.sort();
    assert_eq!(
        shade, every,
        "lineup.toml: one shade pipeline per registered analytic model"
    );
}

#[test]
fn glossy_cornell_box_gpu_matches_cpu() {
    let pipelines = same_seed_parity("cornell-box-glossy.toml", 64, 64, 4, 8);
    let shade: Vec<&String> = pipelines
        .iter()
        .filter(|p| p.starts_with("shade_"))
        .collect();
    assert_eq!(shade, ["shade_lambert", "shade_cook_torrance"]);
}

#[test]
fn anisotropic_scene_gpu_matches_cpu() {
    same_seed_parity("anisotropic.toml", 120, 50, 4, 5);
}

/// Deep paths: 400 segments through every model's shade pipeline need more timestamp queries than
/// one command buffer holds (about 12 per segment, 4096 in all), so the GPU renderer splits the
/// wave over several submissions; the image still matches the CPU reference.
#[test]
fn deep_paths_split_the_command_buffer_and_still_match_the_cpu() {
    same_seed_parity("lineup.toml", 64, 20, 2, 400);
}
