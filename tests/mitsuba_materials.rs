//! Environment maps and bitmap textures render like Mitsuba 3's: two scenes written by
//! `brdfwave convert` (an `envmap` around a diffuse and a rough-gold sphere; `bitmap` textures
//! on a sphere's colour, a rough conductor's roughness and the floor's colour, read through the
//! floor's OBJ texture coordinates and the sphere's own), rendered by Mitsuba from the XML and
//! by brdfwave, compared block by block (two-sample z, Bonferroni over the blocks) and by their
//! mean luminance (within 0.5 %). Opt-in (about 20 s): `cargo test --release --test
//! mitsuba_materials -- --ignored`. It needs Mitsuba 3 (`pip install mitsuba numpy`); without
//! it the tests say so and pass, since a fresh machine does not have it.

mod common;

use brdfwave::imageio::{self, Image};
use std::path::Path;
use std::process::Command;

/// 16 × 16 blocks of a 128 × 128 image: 64 blocks.
const BLOCK: usize = 16;
const SIZE: u32 = 128;
/// Mitsuba: 16 renders of 8 samples (15 degrees of freedom for its standard errors).
const MI_RENDERS: usize = 16;
const MI_SPP: usize = 8;
/// brdfwave's samples per pixel.
const SPP: u32 = 128;
/// 64 blocks at a family-wise false-alarm rate of 1e-3: |z| < 4.3 (Bonferroni, normal tails;
/// the peer's 15 degrees of freedom make the threshold a little generous).
const Z_MAX: f64 = 4.3;

/// Writes `toml` as `dir/NAME.toml`, converts it to `dir/NAME.xml`, renders the XML on the
/// CPU (the independent sampler) and compares it with Mitsuba's renders of the same XML.
fn agree(dir: &Path, name: &str, toml: &str) {
    let src = dir.join(format!("{name}.toml"));
    std::fs::write(&src, toml).unwrap();
    let xml = dir.join(format!("{name}.xml"));
    common::run_ok(
        Command::new(env!("CARGO_BIN_EXE_brdfwave"))
            .args(["convert", src.to_str().unwrap(), "--to", "mitsuba"])
            .arg(&xml),
    );
    let Some(peer) = common::mitsuba::block_means(&xml, BLOCK, MI_RENDERS, MI_SPP) else {
        println!("skipped: Mitsuba 3 is not installed (pip install mitsuba numpy)");
        return;
    };
    let exr = dir.join(format!("{name}.exr"));
    let ours = common::mitsuba::render_ours(&xml, SPP as usize, &exr);
    assert_eq!((ours.image.width, ours.image.height), (SIZE, SIZE));
    let (z, ratio) = common::mitsuba::compare(&ours, SPP as f64, 1.0, BLOCK, &peer);
    println!("{name}: worst block |z| {z:.2}, mean luminance brdfwave / Mitsuba = {ratio:.4}");
    assert!(
        z < Z_MAX,
        "{name}: brdfwave and Mitsuba disagree: worst block |z| = {z:.2}"
    );
    assert!(
        (ratio - 1.0).abs() < 0.005,
        "{name}: the means differ by {:.2} %",
        100.0 * (ratio - 1.0)
    );
    // The test can fail: the same image 3 % brighter is caught.
    let (z, _) = common::mitsuba::compare(&ours, SPP as f64, 1.03, BLOCK, &peer);
    assert!(
        z > Z_MAX,
        "{name}: a 3 % brighter image was not caught (|z| = {z:.2})"
    );
}

/// The camera, film and integrator of both scenes.
fn head(extra: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 1.2, -4.5]\ntarget = [0.0, 0.45, 0.0]\nfov_y = 30.0\n\
         [film]\nwidth = {SIZE}\nheight = {SIZE}\n\
         [integrator]\nmax_depth = 6\nsampler = \"independent\"\n{extra}"
    )
}

fn studio() -> String {
    common::repo()
        .join("scenes/material-preview/studio.hdr")
        .display()
        .to_string()
}

const FLOOR: &str = "[[shapes]]\nmaterial = \"floor\"\n\
    quads = [[[-4.0, 0.0, -3.0], [-4.0, 0.0, 5.0], [4.0, 0.0, 5.0], [4.0, 0.0, -3.0]]]\n";

const GOLD: &str = "model = \"cook_torrance\"\nkd = 0.0\ndistribution = \"ggx\"\n\
    geometry = \"smith\"\nnormalization = \"walter\"\nfresnel = \"conductor\"\n";

/// An environment map (the material preview's studio, turned and scaled) lights a diffuse
/// sphere, a rough gold one and a diffuse floor.
#[test]
#[ignore = "opt-in: needs Mitsuba 3 and takes seconds (docs/scenes.md, Mitsuba 3 XML scenes)"]
fn an_envmap_scene_renders_like_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let toml = head(&format!(
        "[environment]\nmap = \"{}\"\nscale = 0.6\n\
         transform = {{ rotate = {{ axis = [0.0, 1.0, 0.0], angle_deg = 40.0 }} }}\n\
         [materials.white]\nmodel = \"lambert\"\nalbedo = 0.7\n\
         [materials.gold]\n{GOLD}roughness = 0.3\n\
         [materials.floor]\nmodel = \"lambert\"\nalbedo = [0.5, 0.45, 0.4]\n\
         [[shapes]]\nmaterial = \"white\"\nsphere = {{ center = [-0.6, 0.5, 0.0], radius = 0.5 }}\n\
         [[shapes]]\nmaterial = \"gold\"\nsphere = {{ center = [0.6, 0.5, 0.0], radius = 0.5 }}\n{FLOOR}",
        studio()
    ));
    agree(dir.path(), "envmap", &toml);
}

/// Bitmap textures: an sRGB PNG on a sphere's colour (its own (u, v)) and on the floor's (the
/// OBJ texture coordinates `convert` writes, scaled by `to_uv`), a linear EXR on a rough
/// conductor's roughness; lit by the studio map.
#[test]
#[ignore = "opt-in: needs Mitsuba 3 and takes seconds (docs/scenes.md, Mitsuba 3 XML scenes)"]
fn a_textured_scene_renders_like_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = common::repo()
        .join("scenes/material-preview/ground.png")
        .display()
        .to_string();
    let rough = dir.path().join("rough.exr");
    imageio::write(
        &rough,
        &Image::from_fn(32, 16, |x, y| {
            [0.05 + 0.4 * ((x as f32 / 31.0) * (y as f32 / 15.0)).sqrt(); 3]
        }),
    )
    .unwrap();
    let toml = head(&format!(
        "[environment]\nmap = \"{}\"\nscale = 0.6\n\
         [materials.painted]\nmodel = \"lambert\"\nalbedo = {{ texture = \"{tiles}\" }}\n\
         [materials.metal]\n{GOLD}roughness = {{ texture = \"{}\" }}\n\
         [materials.floor]\nmodel = \"lambert\"\n\
         albedo = {{ texture = \"{tiles}\", to_uv = {{ scale = [2.0, 3.0], translate = [0.25, 0.0] }} }}\n\
         [[shapes]]\nmaterial = \"painted\"\nsphere = {{ center = [-0.6, 0.5, 0.0], radius = 0.5 }}\n\
         [[shapes]]\nmaterial = \"metal\"\nsphere = {{ center = [0.6, 0.5, 0.0], radius = 0.5 }}\n{FLOOR}",
        studio(),
        rough.display()
    ));
    agree(dir.path(), "textured", &toml);
}

/// A thin lens (Mitsuba's `thinlens`), focused on the nearer sphere, with the envmap scene's
/// lighting.
#[test]
#[ignore = "opt-in: needs Mitsuba 3 and takes seconds (docs/scenes.md, Mitsuba 3 XML scenes)"]
fn a_thin_lens_renders_like_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let toml = head(&format!(
        "[environment]\nmap = \"{}\"\nscale = 0.6\n\
         [materials.white]\nmodel = \"lambert\"\nalbedo = 0.7\n\
         [materials.gold]\n{GOLD}roughness = 0.3\n\
         [materials.floor]\nmodel = \"lambert\"\nalbedo = [0.5, 0.45, 0.4]\n\
         [[shapes]]\nmaterial = \"white\"\nsphere = {{ center = [-0.6, 0.5, -1.0], radius = 0.5 }}\n\
         [[shapes]]\nmaterial = \"gold\"\nsphere = {{ center = [0.6, 0.5, 1.5], radius = 0.5 }}\n{FLOOR}",
        studio()
    ))
    .replace("fov_y = 30.0\n", "fov_y = 30.0\naperture_radius = 0.2\nfocus_distance = 3.6\n");
    agree(dir.path(), "thinlens", &toml);
}
