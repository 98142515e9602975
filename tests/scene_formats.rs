//! Files that are not brdfwave scenes: each is named for what it looks like, with the file
//! and what brdfwave reads instead, never as a TOML syntax error about line 1.

use brdfwave::scene::load;

fn error_of(name: &str, content: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, content).unwrap();
    match load(&path) {
        Ok(_) => panic!("{name} loaded"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn other_formats_are_named() {
    let cases: &[(&str, &[u8], &str)] = &[
        (
            "s.pbrt",
            b"LookAt 0 0 5 0 0 0 0 1 0\nCamera \"perspective\" \"float fov\" [45]\nWorldBegin\n",
            "a pbrt scene",
        ),
        // Named `.xml`, a Mitsuba scene is read as one; under another name it is recognised.
        (
            "s.scene",
            b"<scene version=\"3.0.0\">\n  <shape type=\"sphere\"/>\n</scene>\n",
            "a Mitsuba scene (XML)",
        ),
        ("m.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "an OBJ mesh"),
        (
            "m.ply",
            b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nend_header\n\xff\xfe\x00\x80",
            "a PLY mesh",
        ),
        ("s.json", b"{\"camera\": {\"fov\": 45}}\n", "a JSON file"),
    ];
    for (name, content, kind) in cases {
        let e = error_of(name, content);
        assert!(
            e.contains(name) && e.contains(&format!("this looks like {kind}")),
            "{name}: {e}"
        );
        assert!(e.contains("brdfwave reads TOML scenes"), "{name}: {e}");
        assert_eq!(
            e.contains("a mesh goes into a scene"),
            kind.ends_with("mesh"),
            "{e}"
        );
    }
}

#[test]
fn a_broken_toml_scene_keeps_its_located_error() {
    let e = error_of("s.toml", b"[camera]\nposition = [0, 1, 5\n");
    assert!(e.contains("s.toml:") && !e.contains("looks like"), "{e}");
    // Binary junk that is nothing known keeps the UTF-8 error.
    let e = error_of("s.toml", b"\xff\xfe\x00junk");
    assert!(e.contains("not UTF-8") && !e.contains("looks like"), "{e}");
}
