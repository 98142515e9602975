//! Content sniffing for the loader's errors: when a scene file is not TOML (or not text), what
//! it looks like instead, so that a user who passes a pbrt scene, a mesh or a JSON file as the
//! scene is told so instead of getting a TOML syntax error about line 1.
//!
//! [`describe`] only looks at the content (not the file name), and only strong evidence
//! counts: it is called after the TOML parser has failed, and a TOML scene with a typo must
//! keep its own, located, message.

/// What brdfwave reads, appended to every "this looks like …" message.
pub(super) const READS: &str = "brdfwave reads TOML scenes and, from files named *.xml, Mitsuba 3 XML scenes (both in scenes/README.md)";

/// How many meaningful (non-blank, non-comment) lines the line-based formats are judged on.
const LINES: usize = 20;

/// What the bytes of a file that is not a TOML scene look like, e.g. `"a pbrt scene"`, or
/// `None` when nothing is recognized (the caller then reports its own error).
pub fn describe(bytes: &[u8]) -> Option<&'static str> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n") {
        return Some("a PLY mesh");
    }
    if bytes.starts_with(b"glTF") {
        return Some("a binary glTF file");
    }
    // The text formats are judged on the file's first few kilobytes (a binary file has no
    // valid text beyond its header).
    let head = &bytes[..bytes.len().min(64 * 1024)];
    let text = match std::str::from_utf8(head) {
        Ok(t) => t,
        Err(e) => std::str::from_utf8(&head[..e.valid_up_to()]).unwrap_or(""),
    };
    let start = text.trim_start();
    if start.starts_with('<') {
        return Some(if start.contains("<scene") {
            "a Mitsuba scene (XML)"
        } else {
            "an XML file"
        });
    }
    if (start.starts_with('{') || start.starts_with('['))
        && serde_json::from_slice::<serde::de::IgnoredAny>(bytes).is_ok()
    {
        return Some(if start.starts_with('{') && text.contains("\"asset\"") {
            "a glTF file (JSON)"
        } else {
            "a JSON file"
        });
    }
    let lines: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .take(LINES)
        .collect();
    if lines.is_empty() {
        return None;
    }
    if is_pbrt(&lines) {
        return Some("a pbrt scene");
    }
    let first_words = || lines.iter().filter_map(|l| l.split_whitespace().next());
    if first_words().any(|w| w == "newmtl")
        && first_words().all(|w| MTL_KEYWORDS.contains(&w) || w.starts_with("map_"))
    {
        return Some("an MTL material library");
    }
    if first_words().any(|w| w == "v" || w == "f")
        && first_words().all(|w| OBJ_KEYWORDS.contains(&w))
    {
        return Some("an OBJ mesh");
    }
    None
}

/// Whether a [`describe`] answer is XML (a Mitsuba scene or another XML file).
pub(super) fn is_xml_kind(kind: &str) -> bool {
    kind.contains("XML")
}

/// The statements of an OBJ file.
const OBJ_KEYWORDS: &[&str] = &[
    "v", "vt", "vn", "vp", "f", "l", "p", "o", "g", "s", "mtllib", "usemtl",
];

/// The statements of an MTL file (`map_*` aside).
const MTL_KEYWORDS: &[&str] = &[
    "newmtl", "Ka", "Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "Tf", "illum", "bump", "disp",
    "decal", "refl", "Pr", "Pm", "Ps", "Pc", "Pcr", "aniso", "anisor", "norm",
];

/// The directives of pbrt-v3 and pbrt-v4 scene files.
const PBRT_DIRECTIVES: &[&str] = &[
    "LookAt",
    "Camera",
    "Film",
    "Sampler",
    "Integrator",
    "PixelFilter",
    "Accelerator",
    "ColorSpace",
    "Option",
    "WorldBegin",
    "WorldEnd",
    "AttributeBegin",
    "AttributeEnd",
    "TransformBegin",
    "TransformEnd",
    "Shape",
    "Material",
    "MakeNamedMaterial",
    "NamedMaterial",
    "LightSource",
    "AreaLightSource",
    "Texture",
    "Translate",
    "Rotate",
    "Scale",
    "Transform",
    "ConcatTransform",
    "CoordinateSystem",
    "CoordSysTransform",
    "Include",
    "Import",
    "MakeNamedMedium",
    "MediumInterface",
    "ObjectBegin",
    "ObjectEnd",
    "ObjectInstance",
    "ReverseOrientation",
    "Attribute",
];

/// Every judged line starts with a pbrt directive, and none is a TOML assignment.
fn is_pbrt(lines: &[&str]) -> bool {
    lines.iter().all(|l| {
        let mut words = l.split_whitespace();
        let first = words.next().unwrap_or("");
        let second = words.next().unwrap_or("");
        // Parameter lists continue on the next lines: `"float fov" [ 45 ]`.
        (PBRT_DIRECTIVES.contains(&first) && second != "=")
            || first.starts_with('"')
            || (l.starts_with('[') && !toml_header(l))
    })
}

/// `[name]` or `[[name.sub]]`: a TOML table header (pbrt's value lists, `[ 400 ]` or
/// `[ "a" ]`, start with a number or a string).
fn toml_header(l: &str) -> bool {
    let inner = l.trim_start_matches('[').trim_start();
    inner.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognizes_each_format() {
        let cases: &[(&[u8], &str)] = &[
            (b"ply\nformat ascii 1.0\nelement vertex 3\n", "a PLY mesh"),
            (b"ply\r\nformat binary_little_endian 1.0\r\n\x00\xff", "a PLY mesh"),
            (
                b"<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n</scene>\n",
                "a Mitsuba scene (XML)",
            ),
            (b"<svg></svg>", "an XML file"),
            (b"{\"camera\": {\"fov\": 45}}", "a JSON file"),
            (b"[1, 2, 3]", "a JSON file"),
            (b"{\"asset\": {\"version\": \"2.0\"}}", "a glTF file (JSON)"),
            (b"glTF\x02\x00\x00\x00", "a binary glTF file"),
            (
                b"# pbrt-v4\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\n\
                  Film \"rgb\"\n    \"integer xresolution\" [ 400 ]\n    [ 1 2 ]\nWorldBegin\n",
                "a pbrt scene",
            ),
            (
                b"# Blender\nmtllib a.mtl\no Cube\nv 1 1 1\nv 1 0 1\nv 0 0 1\nvn 0 0 1\nusemtl m\ns off\nf 1//1 2//1 3//1\n",
                "an OBJ mesh",
            ),
            (
                b"newmtl white\nKd 0.8 0.8 0.8\nNs 10\nillum 2\nmap_Kd a.png\n",
                "an MTL material library",
            ),
        ];
        for (bytes, want) in cases {
            assert_eq!(
                describe(bytes),
                Some(*want),
                "{:?}",
                String::from_utf8_lossy(bytes)
            );
        }
    }

    #[test]
    fn broken_toml_is_not_described() {
        for text in [
            "[camera]\nposition = [0, 1, 5\n",
            "[[shapes]]\nmaterial = \"a\"\nv 1 2 3\n",
            "Camera = 3\nFilm = \"x\"\n",
            "[film]\nwidth = 1\n[1, 2]\n",
            "",
            "\n# only a comment\n",
            "[materials.white\nmodel = \"lambert\"\n",
            "{ not json",
        ] {
            assert_eq!(describe(text.as_bytes()), None, "{text:?}");
        }
    }
}
