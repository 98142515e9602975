//! The small valid scene that the scene-file tests edit (`tests/scene_load.rs`,
//! `tests/scene_errors.rs`), and how they load an edit and check its error.

use brdfwave::scene::{load_str, Scene};
use std::path::{Path, PathBuf};

/// A small valid scene (lines numbered for reading the cases that edit it).
pub const BASE: &str = r#"[camera]
position = [0.0, 0.0, -4.0]
target = [0.0, 0.0, 0.0]
fov_y = 40.0

[film]
width = 8
height = 8

[materials.m]
model = "lambert"

[[shapes]]
material = "m"
emission = [1.0, 1.0, 1.0]
sphere = { center = [0.0, 0.0, 0.0], radius = 1.0 }
"#;

/// BASE with one edit; the edited text must be there.
pub fn with(from: &str, to: &str) -> String {
    assert!(BASE.contains(from), "test bug: '{from}' is not in BASE");
    BASE.replacen(from, to, 1)
}

/// The error of loading `src` as `dir/bad.toml`, which must fail.
pub fn error_of(src: &str) -> String {
    match load_str(src, Path::new("dir/bad.toml")) {
        Ok(_) => panic!("loaded without error:\n{src}"),
        Err(e) => e.to_string(),
    }
}

/// The error names the file, the line where `at` is, the field, and says `what`.
#[track_caller]
pub fn expect_error(src: &str, at: &str, field: &str, what: &str) {
    let msg = error_of(src);
    let field = format!("field '{field}'");
    super::assert_located(&msg, ("dir/bad.toml", src), at, &[&field, what]);
}

/// Some warning of the scene contains `needle`.
#[track_caller]
pub fn assert_warned(s: &Scene, needle: &str) {
    assert!(
        s.warnings.iter().any(|w| w.contains(needle)),
        "want a warning with '{needle}': {:?}",
        s.warnings
    );
}

/// The scene has exactly one warning, and it contains `needle`.
#[track_caller]
pub fn assert_one_warning(s: &Scene, needle: &str) {
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_warned(s, needle);
}

/// A scratch directory with a scene and an OBJ file side by side.
pub fn scene_with_obj(obj: &str, extra: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
    let scene = format!("{BASE}\n[[shapes]]\nmaterial = \"m\"\nobj = \"mesh.obj\"\n{extra}");
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    (dir, path)
}

/// A unit quad in z = 0 with texture coordinates, as an OBJ file.
pub const QUAD_OBJ: &str =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";

/// The cube [−1, 1]³ as OBJ quads, wound to face out: vertex i (from 1) is the corner whose
/// x, y, z are +1 where bits 0, 1, 2 of i − 1 are set.
pub const CUBE_QUADS: [[usize; 4]; 6] = [
    [1, 3, 4, 2],
    [5, 6, 8, 7],
    [1, 2, 6, 5],
    [3, 7, 8, 4],
    [1, 5, 7, 3],
    [2, 4, 8, 6],
];
