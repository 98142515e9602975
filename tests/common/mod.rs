//! Helpers shared by the integration tests that render.
#![allow(dead_code)]

pub mod brdf;
pub mod bvh;
pub mod cli;
pub mod mitsuba;
pub mod scene_file;

use brdfwave::film::Tile;
use brdfwave::gpu::GpuOptions;
use brdfwave::metrics;
use brdfwave::output::RenderOutput;
use brdfwave::render::{self, Backend, RenderRequest};
use brdfwave::scene::{self, Scene};
use brdfwave::vk::{Context, ContextOptions, ShaderCompiler};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The test process's scratch folder `brdfwave-TAG-PID` in the system's temporary folder, made
/// when missing. At its first use in a process it is emptied (a folder of this name left by an
/// earlier process with the same id would hand its files to this one: a bench reference cached
/// there by another build made a test find two), and the folders of the same tag whose process
/// has ended are removed, so that test runs do not pile them up; those of the last run stay,
/// to look at after a failure.
pub fn scratch(tag: &'static str) -> PathBuf {
    use std::sync::Mutex;
    static STARTED: Mutex<Vec<&'static str>> = Mutex::new(Vec::new());
    let tmp = std::env::temp_dir();
    let d = tmp.join(format!("brdfwave-{tag}-{}", std::process::id()));
    let mut started = STARTED.lock().unwrap_or_else(|e| e.into_inner());
    if !started.contains(&tag) {
        let _ = std::fs::remove_dir_all(&d);
        remove_ended(&tmp, tag);
        started.push(tag);
    }
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Removes `brdfwave-TAG-PID` folders in `tmp` whose process no longer runs (Linux: no
/// `/proc/PID`; elsewhere nothing is removed).
fn remove_ended(tmp: &Path, tag: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let prefix = format!("brdfwave-{tag}-");
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// Runs `cmd` and requires it to exit 0; a failure shows the command and its stderr.
#[track_caller]
pub fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().expect("the command starts");
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Writes the measured table of `scenes/material-preview.toml` (35 MB, not committed) when it
/// is missing, by running `scripts/material-preview.sh` with this build's program (`brdf merl`
/// of the material in `scenes/material-preview/measured.material`). Tests that load every
/// shipped scene call it first. The file is written atomically, so tests running at once may
/// both write it.
pub fn material_preview_table() {
    if repo()
        .join("scenes/material-preview/measured.binary")
        .is_file()
    {
        return;
    }
    run_ok(
        Command::new("bash")
            .arg(repo().join("scripts/material-preview.sh"))
            .env("BRDFWAVE", env!("CARGO_BIN_EXE_brdfwave")),
    );
    assert!(repo()
        .join("scenes/material-preview/measured.binary")
        .is_file());
}

/// The `render` options of a quick check of the command line: CPU, 8×8, one sample per pixel.
pub const QUICK_RENDER: [&str; 6] = ["--backend", "cpu", "--res", "8x8", "--spp", "1"];

/// Load a scene from `scenes/` and override size, spp, depth and seed.
pub fn scene(name: &str, w: u32, h: u32, spp: u32, max_depth: u32, seed: u32) -> Scene {
    let mut s = scene::load(&repo().join("scenes").join(name)).expect("scene loads");
    s.width = w;
    s.height = h;
    s.integrator.spp = spp;
    s.integrator.max_depth = max_depth;
    s.integrator.seed = seed;
    s
}

/// A Vulkan context on the default device (lavapipe in CI) with validation enabled when the
/// layer is installed. Fails (does not skip) when Vulkan is unavailable.
pub fn context() -> Context {
    Context::new(&ContextOptions {
        device: None,
        validation: true,
        ray_query: false,
    })
    .expect("a Vulkan device (install mesa-vulkan-drivers)")
}

/// The per-pixel two-sample z-test of two renders' means at alpha 0.01 with the pooled
/// (Student) variance: the calibrated choice when both run the same estimator (Welch is
/// anti-conservative for skewed per-sample distributions).
pub fn pooled_z_test(a: &RenderOutput, b: &RenderOutput) -> metrics::ZTestReport {
    let opts = metrics::ZTestOptions {
        alpha: 0.01,
        variance: metrics::VarianceModel::Pooled,
        ..Default::default()
    };
    metrics::z_test_with(
        &a.mean,
        &a.variance,
        a.spp as u64,
        &b.mean,
        &b.variance,
        b.spp as u64,
        &opts,
    )
    .unwrap()
}

/// Render on the CPU reference, through the renderer interface (`brdfwave::render`).
pub fn render_cpu(s: &Scene) -> RenderOutput {
    render::render_whole(Backend::Cpu, s).expect("CPU render")
}

/// Renders `s` on the CPU and on the GPU (a context of its own, checked for validation messages
/// at teardown): the outputs named "cpu" and "gpu".
pub fn render_both(s: &Scene) -> [(&'static str, RenderOutput); 2] {
    let ctx = context();
    let (gpu, _) = render_gpu(&ctx, s);
    finish(ctx);
    [("cpu", render_cpu(s)), ("gpu", gpu)]
}

/// Render on the GPU; returns the output and the names of the pipelines built. Fails the test
/// if the validation layer reported anything.
pub fn render_gpu(ctx: &Context, s: &Scene) -> (RenderOutput, Vec<String>) {
    render_gpu_wave(ctx, s, brdfwave::gpu::MAX_WAVE_PATHS)
}

/// [`render_gpu`] with at most `wave_paths` paths in flight.
pub fn render_gpu_wave(ctx: &Context, s: &Scene, wave_paths: u32) -> (RenderOutput, Vec<String>) {
    let b = brdfwave::bvh::build(s);
    let compiler = ShaderCompiler::new().expect("shader compiler");
    let (out, pipelines) = {
        let backend = Backend::Gpu {
            ctx,
            compiler: &compiler,
            options: GpuOptions {
                wave_paths,
                ..GpuOptions::default()
            },
        };
        let mut r = render::open(backend, s, b.into(), Tile::full(s.width, s.height))
            .expect("GPU renderer set-up");
        let request = RenderRequest::samples(0..s.integrator.spp);
        let out = r.render(&request, &|_| {}).expect("GPU render").output;
        let pipelines = r.describe().gpu.expect("a GPU renderer").setup.pipelines;
        (out, pipelines)
    };
    let msgs = ctx.validation_messages();
    assert!(
        msgs.is_empty(),
        "validation layer messages:\n{}",
        msgs.join("\n")
    );
    (out, pipelines)
}

/// Renders `s` on the GPU and on the CPU at the same seed (the two follow the same paths) and
/// requires 98% of the pixel-channels to agree (2e-3 relative, 1e-4 absolute) and no non-finite
/// sample on either side; on failure saves `<stem>-gpu.exr`, `<stem>-cpu.exr` and an error map.
/// Returns the names of the GPU pipelines built.
pub fn same_seed_parity(s: &Scene, stem: &str) -> Vec<String> {
    let ctx = context();
    let (gpu, pipelines) = render_gpu(&ctx, s);
    let cpu = render_cpu(s);
    assert_eq!(gpu.nonfinite_samples, 0, "{stem}: GPU non-finite samples");
    assert_eq!(cpu.nonfinite_samples, 0, "{stem}: CPU non-finite samples");
    let agree = metrics::fraction_within(&gpu.mean, &cpu.mean, 2e-3, 1e-4).unwrap();
    if agree.channel_fraction < 0.98 {
        save(&format!("{stem}-gpu.exr"), &gpu.mean);
        save(&format!("{stem}-cpu.exr"), &cpu.mean);
        save(
            &format!("{stem}-error.png"),
            &metrics::error_map(&gpu.mean, &cpu.mean).unwrap(),
        );
        panic!("{stem}: need 98% of pixel-channels to agree: {agree}");
    }
    finish(ctx);
    pipelines
}

/// Tear the context down and fail on any validation message, including those raised at device
/// destruction (leaked objects).
pub fn finish(ctx: Context) {
    let msgs = ctx.finish();
    assert!(
        msgs.is_empty(),
        "validation layer messages at teardown:\n{}",
        msgs.join("\n")
    );
}

/// Where tests write images for inspection on failure.
pub fn artifact_dir() -> PathBuf {
    let d = repo().join("target").join("test-artifacts");
    std::fs::create_dir_all(&d).unwrap();
    d
}

pub fn save(name: &str, img: &brdfwave::imageio::Image) -> PathBuf {
    let p = artifact_dir().join(name);
    brdfwave::imageio::write(&p, img).expect("write artifact");
    p
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}

/// The 1-based line of the first `needle` in `text`.
pub fn line_of(text: &str, needle: &str) -> usize {
    let at = text
        .find(needle)
        .unwrap_or_else(|| panic!("test bug: '{needle}' not in the text"));
    text[..at].matches('\n').count() + 1
}

/// Asserts that the error `msg` about the file `file` starts with `FILE:LINE: `, the line of
/// `at` in the file's text `src`, and contains every `what`.
#[track_caller]
pub fn assert_located(msg: &str, (file, src): (&str, &str), at: &str, what: &[&str]) {
    let line = line_of(src, at);
    assert!(
        msg.starts_with(&format!("{file}:{line}: ")),
        "want line {line}: {msg}"
    );
    assert_mentions(msg, what);
}

/// `text` contains every one of `needles`; a failure names the one missing and shows the text.
#[track_caller]
pub fn assert_mentions(text: &str, needles: &[&str]) {
    for n in needles {
        assert!(text.contains(n), "no {n:?} in:\n{text}");
    }
}
