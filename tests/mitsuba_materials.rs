//! Environment maps and bitmap textures render like Mitsuba 3's: scenes written by `brdfwave
//! convert` (an `envmap` around a diffuse and a rough-gold sphere; `bitmap` textures on a
//! sphere's colour, a rough conductor's roughness and the floor's colour, read through the
//! floor's OBJ texture coordinates and the sphere's own) and by hand (Mitsuba's own shapes,
//! textured, turned and mirrored; the readings of Mitsuba's that its documentation does not
//! spell out), rendered by Mitsuba from the XML and
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

/// Writes `toml` as `dir/NAME.toml`, converts it to `dir/NAME.xml`, and compares the XML's
/// renders ([`compare_renders`]).
fn agree(dir: &Path, name: &str, toml: &str) {
    let src = dir.join(format!("{name}.toml"));
    std::fs::write(&src, toml).unwrap();
    let xml = dir.join(format!("{name}.xml"));
    common::run_ok(
        Command::new(env!("CARGO_BIN_EXE_brdfwave"))
            .args(["convert", src.to_str().unwrap(), "--to", "mitsuba"])
            .arg(&xml),
    );
    compare_renders(dir, name, &xml);
}

/// Writes the hand-written scene `text` as `dir/NAME.xml` and compares its renders
/// ([`compare_renders`]).
fn agree_xml(dir: &Path, name: &str, text: &str) {
    let path = dir.join(format!("{name}.xml"));
    std::fs::write(&path, text).unwrap();
    compare_renders(dir, name, &path);
}

/// Renders the XML scene `xml` on the CPU (the independent sampler) and compares it with
/// Mitsuba's renders of the same XML.
fn compare_renders(dir: &Path, name: &str, xml: &Path) {
    let xml = xml.to_path_buf();
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

/// Mitsuba's own shapes as a user writes them, textured and placed every way that turns or
/// mirrors them: a sphere turned about two axes (its texture turns with it), a disk, a cube,
/// a rectangle with `flip_normals` and one mirrored by its `to_world` (whose front side stays
/// the one Mitsuba's normals face), under a constant sky.
#[test]
#[ignore = "opt-in: needs Mitsuba 3 and takes seconds (docs/scenes.md, Mitsuba 3 XML scenes)"]
fn mitsubas_own_shapes_render_like_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    // Four coloured quadrants, each another colour.
    let quadrants = Image::from_fn(8, 8, |x, y| match (x < 4, y < 4) {
        (true, true) => [0.8, 0.1, 0.1],
        (false, true) => [0.1, 0.7, 0.1],
        (true, false) => [0.1, 0.2, 0.8],
        (false, false) => [0.8, 0.7, 0.1],
    });
    imageio::write(&dir.path().join("quadrants.exr"), &quadrants).unwrap();
    let tex = r#"<bsdf type="twosided"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="quadrants.exr"/><string name="filter_type" value="nearest"/></texture></bsdf></bsdf>"#;
    // Each shape's texture has a wrap mode of its own (the same lookups inside [0, 1]²): Mitsuba
    // merges the meshes of one BSDF into one, and fails on ones it cannot merge.
    let count = std::cell::Cell::new(0);
    let shape = |kind: &str, inside: &str| {
        let k = count.get();
        count.set(k + 1);
        let (wrap, filter) = [
            ("repeat", "nearest"),
            ("mirror", "nearest"),
            ("clamp", "nearest"),
            ("repeat", "bilinear"),
            ("mirror", "bilinear"),
        ][k];
        let lookup = format!(
            r#"<string name="filter_type" value="{filter}"/><string name="wrap_mode" value="{wrap}"/>"#
        );
        let tex = tex.replace(r#"<string name="filter_type" value="nearest"/>"#, &lookup);
        format!("<shape type=\"{kind}\">{inside}{tex}</shape>\n")
    };
    let xf = |steps: &str| format!("<transform name=\"to_world\">{steps}</transform>");
    let mut body = String::new();
    body += &shape(
        "sphere",
        &format!(
            "<point name=\"center\" value=\"-1.2, 0.5, 0.5\"/><float name=\"radius\" value=\"0.5\"/>{}",
            xf(r#"<rotate x="1" angle="-70"/><rotate y="1" angle="30"/>"#)
        ),
    );
    body += &shape(
        "disk",
        &xf(r#"<scale value="0.5"/><rotate y="1" angle="200"/><translate y="1.4"/>"#),
    );
    // (Mitsuba merges the meshes of one BSDF, and cannot merge its cube, which has normals,
    // with the others: the cube's texture is filtered otherwise, which makes its BSDF another.)
    body += &shape(
        "cube",
        &xf(
            r#"<scale value="0.4"/><rotate y="1" angle="35"/><rotate x="1" angle="20"/><translate x="1.2" y="0.5" z="0.5"/>"#,
        ),
    )
    .replace("nearest", "bilinear");
    body += &shape(
        "rectangle",
        &format!(
            "<boolean name=\"flip_normals\" value=\"true\"/>{}",
            xf(r#"<scale value="0.45"/><translate x="-0.5" y="-0.3"/>"#)
        ),
    );
    body += &shape(
        "rectangle",
        &xf(
            r#"<scale x="-0.45" y="0.45"/><rotate y="1" angle="180"/><translate x="0.6" y="-0.3"/>"#,
        ),
    );
    let xml = format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator>\n\
         <sensor type=\"perspective\"><float name=\"fov\" value=\"45\"/>\
         <transform name=\"to_world\"><lookat origin=\"0, 0.8, -5\" target=\"0, 0.5, 0\" up=\"0, 1, 0\"/></transform>\
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"{SIZE}\"/><integer name=\"height\" value=\"{SIZE}\"/><rfilter type=\"box\"/></film></sensor>\n\
         <emitter type=\"constant\"><rgb name=\"radiance\" value=\"1, 1, 1\"/></emitter>\n{body}</scene>\n"
    );
    agree_xml(dir.path(), "shapes", &xml);
}

/// What Mitsuba 3 reads in ways its documentation alone does not tell, in one hand-written
/// scene: a camera without a `fov` (the 50mm default) whose `to_world` mirrors, hidden emitters
/// (an emitting disk the camera sees through, a sky it does not see), an emitter's radiance as a
/// constant `<spectrum>` (a multiple of D65), a cube rotated about an axis that is not a unit
/// vector (taken as written: it also stretches), a twosided BSDF that names its BSDF by `<ref>`
/// and a shape that names a BSDF defined after it.
#[test]
#[ignore = "opt-in: needs Mitsuba 3 and takes seconds (docs/scenes.md, Mitsuba 3 XML scenes)"]
fn mitsubas_readings_render_like_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let xml = format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="4"/><boolean name="hide_emitters" value="true"/></integrator>
<sensor type="perspective">
<transform name="to_world"><scale x="-1"/><lookat origin="0.4, 1.2, -4" target="0, 0.4, 0" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/><rfilter type="box"/></film></sensor>
<emitter type="constant"><spectrum name="radiance" value="0.8"/></emitter>
<bsdf type="diffuse" id="warm"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>
<bsdf type="twosided" id="both"><ref id="warm"/></bsdf>
<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform><ref id="grey"/></shape>
<shape type="cube"><transform name="to_world"><scale value="0.35"/><rotate x="1" y="1" angle="30"/><translate x="-0.6" y="0.5"/></transform><ref id="both"/></shape>
<shape type="disk"><transform name="to_world"><scale value="0.4"/><translate x="0.5" y="0.6" z="-0.5"/></transform>
<emitter type="area"><spectrum name="radiance" value="4"/></emitter></shape>
<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.5"/></bsdf>
</scene>
"#
    );
    agree_xml(dir.path(), "readings", &xml);
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
