//! brdfwave: a Vulkan compute wavefront path tracer and an independent CPU reference renderer
//! for comparing the surface models of the survey "Physically correct surface models".
//!
//! For callers, [`api`] is the entry point: `Scene::load(path)`, then
//! `api::render(&scene, &Options)` gives the image and its statistics (`docs/library.md`;
//! `examples/render_scene.rs`).
//!
//! Where to find things:
//! * `api` — the library entry point above, over `scene` and `render`;
//! * `scene` — scene format and loader (`scenes/README.md` documents the TOML);
//!   `overrides` — `render --set KEY=VALUE`, edits of the scene document before its checks;
//! * `brdf` — one file per reflectance model, or one directory where the model has parts
//!   (`he/`), with GLSL twins of the same names in `shaders/brdf/`;
//! * `bvh` — host binned-SAH BVH, its GPU layout and the CPU traversal (`shaders/bvh.glsl`);
//! * `robust` — robust f32 geometry: error-bounded hit points, ray-origin offsets
//!   (`shaders/robust.glsl`);
//! * `rng` — the counter-based random numbers both renderers share (`shaders/rng.glsl`);
//! * `cpu` — the CPU reference path tracer;
//! * `vk` — the Vulkan backend layer: device, buffers, shader compilation, pipelines;
//! * `gpu` — the wavefront integrator built on `vk` (kernels in `shaders/wavefront/`);
//! * `render` — one `Renderer` interface to both, and the render request: what `render`,
//!   `bench`, `stress` and the tests render through (the commands themselves are `src/cmd/`,
//!   one module each, dispatched by `src/main.rs`);
//! * `camera`, `lights` — camera rays and the emitter table both renderers sample;
//!   `envmap` — environment maps: lookup and importance sampling (`shaders/envmap.glsl`);
//! * `output` — what a render returns, whichever backend made it;
//! * `conventions` — what both renderers agree on (e.g. the ray counts by segment);
//! * `film` — per-pixel sample sums, partial films of split renders, and their exact merge;
//! * `brdf_tools` — `brdfwave brdf eval | plot | report`;
//! * `measured` — measured reflectance tables: the MERL BRDF database's files (`merl`);
//! * `fit` — `brdfwave brdf fit`: the survey's models fitted to a measured table (loss, domain,
//!   parameter space from the registry, Nelder–Mead);
//! * `imageio`, `metrics` — image files and image comparison; `texture` — image textures on
//!   material parameters (`shaders/texture.glsl`);
//! * `memory` — the memory left for a large allocation, asked before making it;
//! * `outfile` — the atomic writer of every file, and the up-front checks of output paths;
//!   `infile` — the one reader of every file a user names: regular files only, bounded, and
//!   remembered so that no output replaces an input; `paths` — which file a path names;
//! * `hash` — the stable hash (FNV-1a) of cache keys and of the scene hash of partial films;
//! * `errors` — how errors read on the command line; `numbers` — user numbers to f32, with
//!   the one check of range every reader shares;
//! * `plot` — the figures (`plotters`, SVG or PNG with the embedded DejaVu Sans, each with its
//!   data as CSV): line charts, polar plots, heat maps with colour bars, and `brdf plot`'s;
//! * `bench` — `brdfwave bench`: run time against error, and its log-log chart
//!   (`src/bench/`: the run in `mod.rs`, and `config`, `runner`, `mitsuba` (the Mitsuba 3
//!   peer), `reference`, `tables` (bench.md's summary), `scaling`).

/// `eprintln!` and `eprint!` that never panic: a message that cannot be written (stderr full or
/// closed) is dropped and the work goes on. They shadow the std macros in every module below
/// (std's panic on a failed write, which stopped a render when stderr was `/dev/full`). Control
/// characters in what they print are escaped but the layout ([`errors::terminal_safe`]).
macro_rules! eprintln {
    () => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr());
    }};
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let text = format!($($arg)*);
        let _ = writeln!(std::io::stderr(), "{}", $crate::errors::terminal_safe(&text));
    }};
}
macro_rules! eprint {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let text = format!($($arg)*);
        let _ = write!(std::io::stderr(), "{}", $crate::errors::terminal_safe(&text));
    }};
}

pub mod api;
pub mod bench;
pub mod brdf;
pub mod brdf_tools;
pub mod bvh;
pub mod camera;
pub mod conventions;
pub mod cpu;
pub mod envmap;
pub mod errors;
pub mod film;
pub mod fit;
pub mod gpu;
pub mod hash;
pub mod imageio;
pub mod infile;
pub mod lights;
pub mod measured;
pub mod memory;
pub mod metrics;
pub mod numbers;
pub mod outfile;
pub mod output;
pub mod overrides;
pub mod paths;
pub mod plot;
pub mod render;
pub mod rng;
pub mod robust;
pub mod scene;
pub mod stress;
pub mod texture;
pub mod vk;
