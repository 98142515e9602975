//! `brdfwave stress`: randomized numerical-stability checks within a time budget.
//!
//! Each group draws cases from a seeded generator: case `i` of group `g` in a run with seed `S`
//! uses the seed `splitmix(S, g, i)`, so a case is reproduced from its group and case seed
//! alone. Failures are printed and written (one JSON object per line: group, seed, message) to
//! the failure file, which `--replay` runs again. The groups:
//!
//! * `models` — every model and variant with parameters drawn across their whole valid range
//!   (log-uniform near the ends: roughness and alphas to 1e-6 or the model's floor, exponents
//!   to 1e6, He σ₀/λ from 1e-4 to 1e2, Schlick p to 1e-4, ior near 1, large κ) and directions
//!   from normal incidence to cos θ = 1e-7, exact mirror and retro-reflection pairs and the
//!   poles of the tangent frame: eval, pdf and sample finite and non-negative, pdf > 0 where a
//!   sample is returned, the weight f·cos/pdf of a non-delta sample; then the same cases on
//!   the GPU (`gpu::brdf_probe`) against the CPU, with the tolerance of
//!   `tests/brdf_gpu_parity.rs`.
//! * `limits` — Oren–Nayar at σ = 0 equals Lambert; the directional albedo of Cook–Torrance
//!   (down to and across its delta switch), Ward (all variants), normalized Phong and
//!   Blinn–Phong, Schlick (continuum form) and He (σ₀/λ → 0) along a roughness sequence: no
//!   jump between steps beyond noise, and the smoothest within noise plus a derived bias of
//!   the analytic specular limit; He's directional-diffuse term tends to Torrance–Sparrow as g
//!   grows, with the gap the second-order expansion predicts.
//! * `gpu_math` — the GLSL helpers (erfc, expm1, log1p, (1 − x)^n for n to 1e6, the He
//!   series) over their input ranges against f64 references, within the precision Vulkan
//!   allows (exp to 3 + 2|x| ulp, log to 3 ulp) with a margin of 2.
//! * `geometry` — the Cornell box scaled by 1e-6..1e6 and moved up to 1e6 renders the
//!   original image (same seed, CPU or GPU) within 0.5 % per channel mean and within noise per
//!   16×16 block (a z-score bound from the per-pixel variances the renderer reports); rays
//!   aimed at the shared edges and vertices of a closed icosphere never pass through it; a
//!   camera inside a closed mesh or sphere sees no environment, on both backends.
//! * `radiance` — emitters and environment scaled by 1e-30..3e38/max(L) scale the image
//!   linearly (CPU and GPU), with no value dropped.
//! * `scene_numbers` — scene files with coordinates, radii and radiance near the f32 limit
//!   load or are refused with a message, never panic; what loads renders without non-finite
//!   values.
//! * `self_shadow` — a lone flat or convex shape (quad, disk, cube, icosphere, sphere up to
//!   radius 1e7) built through each reader (TOML, OBJ, PLY, Mitsuba XML) at scales 1e-4..1e4,
//!   offsets to 1e5 and random rotations, under a sky, a point, a directional or an area
//!   light: no sample may lose its light (false occlusion); a closed room with every light
//!   outside: no pixel may be lit (a leak). Both backends.
//! * `degenerate` — zero-area and sliver triangles, duplicate vertices and faces, coplanar
//!   overlapping faces, huge and tiny spheres (any of them emitting) added to the Cornell box:
//!   no non-finite value and no panic on either backend; as an OBJ file through the loader too.
//!
//! One file per group (`models.rs`, `limits.rs`, `gpu_math.rs`, `geometry.rs`, `radiance.rs`,
//! `scene_numbers.rs`, `self_shadow.rs`, `degenerate.rs`), the harness (`harness.rs`: the group table, what the
//! groups share, the driver and the report) and the random numbers (`rng.rs`).

mod degenerate;
mod geometry;
mod gpu_math;
mod harness;
mod limits;
mod models;
mod radiance;
mod rng;
mod scene_numbers;
mod self_shadow;

pub use geometry::{block_z_max, transform_scene, two_sided_z};
pub use gpu_math::he_series_f64;
pub use harness::{cli, run, CaseResult, Env, Failure, Group, GroupStats, Options, Report, GROUPS};
pub use models::{quiet_material, random_direction, random_material, random_material_of};
pub use rng::{case_seed, Rng};
pub use scene_numbers::numbers_scene;
