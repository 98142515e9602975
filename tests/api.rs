//! The library entry point (`brdfwave::api`): a scene loaded and rendered through it gives the
//! pixels and variance of `brdfwave render` with the same options and seed, bit for bit, on
//! both backends (the GPU one on lavapipe), and statistics that agree with the image.

mod common;
use brdfwave::api::{self, Backend, Options, Scene};
use brdfwave::imageio;
use std::process::Command;

/// Renders the Cornell box at 20x16, 3 spp, seed 5 through `brdfwave render` and returns its
/// EXR's mean and variance layers.
fn cli_render(backend: &str) -> (imageio::Image, imageio::Image) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cli.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .args(["render", "scenes/cornell-box.toml", "--backend", backend])
        .args(["--res", "20x16", "--spp", "3", "--seed", "5", "--quiet"])
        .arg("--out")
        .arg(&out)
        .current_dir(common::repo())
        .status()
        .expect("run brdfwave");
    assert!(status.success(), "brdfwave render failed: {status}");
    let l = imageio::read_layered(&out).expect("the CLI's EXR");
    (l.image, l.variance.expect("a variance layer"))
}

fn check_against_cli(base: Options, backend: &str) {
    let scene = Scene::load(common::repo().join("scenes/cornell-box.toml")).expect("scene");
    let options = Options {
        res: Some((20, 16)),
        spp: Some(3),
        seed: Some(5),
        ..base
    };
    let r = api::render(&scene, &options).expect("API render");
    assert_eq!(r.backend, backend);
    assert!(!r.device.is_empty());
    assert_eq!((r.image.width, r.image.height), (20, 16));
    assert_eq!(r.spp, 3);
    assert!(r.seconds > 0.0 && r.seconds.is_finite(), "{}", r.seconds);
    assert_eq!(r.nonfinite_samples, 0);
    let by_stage: u64 = r.nonfinite_by_stage.iter().map(|(_, n)| n).sum();
    assert_eq!(by_stage, r.nonfinite_samples);
    assert!(r.nonfinite_by_stage.iter().any(|(s, _)| s == "extend"));
    // At least one camera ray per sample of each pixel, and shadow rays from the lit scene.
    assert!(r.extension_rays >= 20 * 16 * 3, "{}", r.extension_rays);
    assert!(r.shadow_rays > 0);
    assert!(r.image.mean().iter().all(|&c| c > 0.01), "a lit image");
    // The scene passed in is not changed.
    assert_ne!(scene.width, 20);

    let (mean, variance) = cli_render(backend);
    assert_eq!(r.image.data, mean.data, "the API's pixels are the CLI's");
    assert_eq!(r.variance.data, variance.data, "and so is the variance");
}

#[test]
fn the_cpu_api_renders_the_cli_image() {
    check_against_cli(Options::cpu(), "cpu");
}

#[test]
fn the_gpu_api_renders_the_cli_image() {
    check_against_cli(Options::gpu(), "gpu");
}

/// Bad options are refused with the option's name, not a panic; a missing scene names its file.
#[test]
fn bad_options_and_files_are_errors() {
    let e = Scene::load("no/such/scene.toml").expect_err("missing file");
    assert!(format!("{e:#}").contains("no/such/scene.toml"), "{e:#}");
    let scene = Scene::load(common::repo().join("scenes/cornell-box.toml")).unwrap();
    let zero = Options {
        spp: Some(0),
        ..Options::cpu()
    };
    let e = api::render(&scene, &zero).err().expect("spp 0");
    assert!(e.to_string().starts_with("--spp"), "{e}");
    let small_wave = Options {
        wave_paths: 1,
        res: Some((4, 4)),
        ..Options::gpu()
    };
    assert_eq!(small_wave.backend, Backend::Gpu);
    let e = api::render(&scene, &small_wave).err().expect("wave of 1");
    assert!(format!("{e:#}").starts_with("wave_paths"), "{e:#}");
}
