//! PLY meshes: the reader against its writer in all three encodings, every scalar type as a
//! value and as a list count, `ply = …` shapes against the same mesh given as OBJ, and bad
//! files (wrong counts, truncated data, memory bombs) refused with located messages.

use brdfwave::scene::ply::{parse, write, Format, PlyMesh};
use brdfwave::scene::{load, shapes::icosphere};
use glam::{Vec2, Vec3};

const FORMATS: [Format; 3] = [
    Format::Ascii,
    Format::BinaryLittleEndian,
    Format::BinaryBigEndian,
];

/// An icosphere with normals and texture coordinates, plus a quad and a pentagon.
fn sample_mesh() -> PlyMesh {
    let (mut positions, tris) = icosphere(1, Vec3::new(0.5, -1.0, 2.0), 1.5);
    let mut faces: Vec<Vec<u32>> = tris.iter().map(|t| t.map(|i| i as u32).to_vec()).collect();
    let base = positions.len() as u32;
    positions.extend([
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(4.0, 1.0, 0.0),
        Vec3::new(3.0, 1.0, 0.0),
        Vec3::new(2.5, 0.5, 0.0),
    ]);
    faces.push(vec![base, base + 1, base + 2, base + 3]);
    faces.push(vec![base, base + 1, base + 2, base + 3, base + 4]);
    // Outward on the sphere, +z on the flat faces (their winding's side).
    let normals = positions
        .iter()
        .enumerate()
        .map(|(i, p)| match i < base as usize {
            true => (*p - Vec3::new(0.5, -1.0, 2.0)).normalize(),
            false => Vec3::Z,
        })
        .collect();
    let uvs = positions
        .iter()
        .map(|p| Vec2::new(p.x, p.y * 0.25))
        .collect();
    PlyMesh {
        positions,
        normals: Some(normals),
        uvs: Some(uvs),
        faces,
    }
}

#[test]
fn round_trips_in_every_encoding() {
    let mut mesh = sample_mesh();
    for with_extras in [true, false] {
        if !with_extras {
            mesh.normals = None;
            mesh.uvs = None;
        }
        for f in FORMATS {
            let bytes = write(&mesh, f);
            let back = parse(&bytes).unwrap_or_else(|e| panic!("{f:?}: {e}"));
            assert_eq!(back, mesh, "{f:?}");
        }
    }
    // Fan triangulation: a quad gives 2 triangles, a pentagon 3, all from the first vertex.
    let m = sample_mesh();
    let tris: Vec<[u32; 3]> = m.triangles().collect();
    assert_eq!(tris.len(), 80 + 2 + 3);
    let b = m.positions.len() as u32 - 5;
    assert_eq!(&tris[80..82], &[[b, b + 1, b + 2], [b, b + 2, b + 3]]);
    assert_eq!(tris[84], [b, b + 3, b + 4]);
}

/// One value of a PLY scalar type, in the given byte order.
fn enc(ty: &str, x: f64, big: bool) -> Vec<u8> {
    macro_rules! e {
        ($t:ty) => {
            if big {
                (x as $t).to_be_bytes().to_vec()
            } else {
                (x as $t).to_le_bytes().to_vec()
            }
        };
    }
    match ty {
        "char" | "int8" => e!(i8),
        "uchar" | "uint8" => e!(u8),
        "short" | "int16" => e!(i16),
        "ushort" | "uint16" => e!(u16),
        "int" | "int32" => e!(i32),
        "uint" | "uint32" => e!(u32),
        "float" | "float32" => e!(f32),
        "double" | "float64" => e!(f64),
        _ => unreachable!(),
    }
}

#[test]
fn every_scalar_type_is_read_as_value_and_count() {
    let types = [
        "char", "uchar", "short", "ushort", "int", "uint", "float", "double", "int8", "uint8",
        "int16", "uint16", "int32", "uint32", "float32", "float64",
    ];
    let ints = [
        "char", "uchar", "short", "ushort", "int", "uint", "int8", "uint8", "int16", "uint16",
        "int32", "uint32",
    ];
    // Positions small integers (exact in every type), plus an ignored property between them.
    let verts = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    for (k, ty) in types.iter().enumerate() {
        let count_ty = ints[k % ints.len()];
        let index_ty = ints[(k + 3) % ints.len()];
        for f in FORMATS {
            let big = f == Format::BinaryBigEndian;
            let name = match f {
                Format::Ascii => "ascii",
                Format::BinaryLittleEndian => "binary_little_endian",
                Format::BinaryBigEndian => "binary_big_endian",
            };
            let mut b = format!(
                "ply\r\nformat {name} 1.0\r\ncomment crlf header\r\nelement vertex 4\r\n\
                 property {ty} x\r\nproperty {ty} y\r\nproperty uchar red\r\nproperty {ty} z\r\n\
                 element face 1\r\nproperty list {count_ty} {index_ty} vertex_indices\r\n\
                 property list uchar float texcoord\r\nend_header\r\n"
            )
            .into_bytes();
            for v in verts {
                if f == Format::Ascii {
                    b.extend(format!("{} {} 7 {}\n", v[0], v[1], v[2]).bytes());
                } else {
                    b.extend(enc(ty, v[0], big));
                    b.extend(enc(ty, v[1], big));
                    b.extend(enc("uchar", 7.0, big));
                    b.extend(enc(ty, v[2], big));
                }
            }
            if f == Format::Ascii {
                b.extend(b"4 0 1 2 3 2 0.5 0.25");
            } else {
                b.extend(enc(count_ty, 4.0, big));
                for i in 0..4 {
                    b.extend(enc(index_ty, i as f64, big));
                }
                b.extend(enc("uchar", 2.0, big));
                b.extend(enc("float", 0.5, big));
                b.extend(enc("float", 0.25, big));
            }
            let m = parse(&b).unwrap_or_else(|e| panic!("{ty}/{count_ty}/{index_ty} {f:?}: {e}"));
            let want: Vec<Vec3> = verts
                .iter()
                .map(|v| Vec3::from_array(v.map(|x| x as f32)))
                .collect();
            assert_eq!(m.positions, want, "{ty} {f:?}");
            assert_eq!(m.faces, vec![vec![0, 1, 2, 3]], "{ty} {f:?}");
            assert!(m.normals.is_none() && m.uvs.is_none());
        }
    }
}

fn ply_error(bytes: &[u8]) -> String {
    match parse(bytes) {
        Ok(_) => panic!("parsed: {}", String::from_utf8_lossy(bytes)),
        Err(e) => e,
    }
}

const TRI_HEADER: &str = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
    property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";

#[test]
fn bad_files_are_refused_with_their_place() {
    let ok = format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert_eq!(parse(ok.as_bytes()).unwrap().faces.len(), 1);
    let cases: Vec<(String, &str)> = vec![
        ("plx\n".into(), "header line 1: a PLY file starts with the line 'ply'"),
        ("ply\nformat ascii 1.0\nelement vertex 3\n".into(), "without 'end_header'"),
        ("ply\nformat ascii 2.0\nend_header\n".into(), "header line 2: unsupported version"),
        ("ply\nformat text 1.0\nend_header\n".into(), "unknown format 'text'"),
        ("ply\nelement vertex 0\nend_header\n".into(), "no 'format' line"),
        ("ply\nformat ascii 1.0\nproperty float x\nend_header\n".into(), "header line 3: a property before"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n".into(), "header line 4: unknown type 'real'"),
        ("ply\nformat ascii 1.0\nelement vertex -1\nend_header\n".into(), "'-1' is not a count"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty list float int i\nend_header\n".into(), "not an integer type"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float x\nend_header\n".into(), "two properties 'x'"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n".into(), "only some of the properties x y z"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float w\nend_header\n0\n".into(), "no properties x y z"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nend_header\n0 0 0 1\n".into(), "only some of the properties nx ny nz"),
        ("ply\nformat ascii 1.0\nelement face 0\nend_header\n".into(), "no 'vertex' element"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"), "line 13: vertex index 3 does not exist (3 vertices"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "line 13: a face needs at least 3 vertices, found 2 (element 'face' 0, property 'vertex_indices')"),
        (format!("{TRI_HEADER}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n"), "line 11: 'zero' is not a number (element 'vertex' 1, property 'y')"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n"), "line 13: 300 is out of the range of its type"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n"), "line 14: '3' follows the last element: the data is longer"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 2 7\n"), "line 13: '7' follows the last element"),
        (format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1\n"), "the data ends (truncated file) (element 'face' 0, property 'vertex_indices')"),
    ];
    for (text, want) in cases {
        let e = ply_error(text.as_bytes());
        assert!(e.contains(want), "{text:?}\n  gave: {e}\n  want: {want}");
    }
}

#[test]
fn binary_errors_name_the_byte_offset_and_element() {
    let mesh = sample_mesh();
    for f in [Format::BinaryLittleEndian, Format::BinaryBigEndian] {
        let bytes = write(&mesh, f);
        // Truncated in the last face: the message names the offset where the data ends.
        let cut = &bytes[..bytes.len() - 2];
        let e = ply_error(cut);
        let last = mesh.faces.len() - 1;
        assert!(
            e.contains(&format!("byte offset {}: the data ends", bytes.len() - 4))
                && e.contains(&format!("element 'face' {last}")),
            "{e}"
        );
        // Junk after the data: a wrong count.
        let mut long = bytes.clone();
        long.extend([0u8; 5]);
        let e = ply_error(&long);
        assert!(
            e.contains(&format!("byte offset {}: 5 byte(s) follow", bytes.len())),
            "{e}"
        );
    }
}

#[test]
fn huge_declared_counts_are_refused_before_allocation() {
    for (decl, what) in [
        ("element vertex 4000000000\nproperty float x\nproperty float y\nproperty float z", "'vertex' declares 4000000000 elements of at least 12 byte(s)"),
        ("element vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 18446744073709551615\nproperty list uint int vertex_indices", "'face' declares 18446744073709551615 elements of at least 4 byte(s)"),
    ] {
        let text = format!("ply\nformat binary_little_endian 1.0\n{decl}\nend_header\n0123456789");
        let e = ply_error(text.as_bytes());
        assert!(e.contains(what) && e.contains("only 10 byte(s) of data follow"), "{e}");
    }
    // A list that declares 4e9 entries runs out of data instead of allocating.
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n".to_vec();
    b.extend([0u8; 36]);
    b.extend(4_000_000_000u32.to_be_bytes());
    b.extend([0u8; 12]);
    let e = ply_error(&b);
    assert!(
        e.contains("the data ends") && e.contains("element 'face' 0"),
        "{e}"
    );
}

/// A scene with one shape of the given geometry line (a mesh file next to it).
fn scene_with(files: &[(&str, &[u8])], shape: &str) -> Result<brdfwave::scene::Scene, String> {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in files {
        std::fs::write(dir.path().join(name), content).unwrap();
    }
    let scene = format!(
        "[camera]\nposition = [0, 0, 8]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 8\nheight = 8\n\
         [environment]\nradiance = 1\n\
         [materials.white]\nmodel = \"lambert\"\nalbedo = 0.5\n[[shapes]]\nmaterial = \"white\"\n{shape}\n"
    );
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    load(&dir.path().join("s.toml")).map_err(|e| e.to_string())
}

fn obj_text(m: &PlyMesh) -> String {
    let mut s = String::new();
    for p in &m.positions {
        s += &format!("v {:?} {:?} {:?}\n", p.x, p.y, p.z);
    }
    for n in m.normals.iter().flatten() {
        s += &format!("vn {:?} {:?} {:?}\n", n.x, n.y, n.z);
    }
    for f in &m.faces {
        let idx: Vec<String> = f.iter().map(|i| format!("{0}//{0}", i + 1)).collect();
        s += &format!("f {}\n", idx.join(" "));
    }
    s
}

#[test]
fn ply_shapes_equal_the_same_mesh_as_obj() {
    let mut mesh = sample_mesh();
    mesh.uvs = None;
    let transform =
        "transform = { translate = [0.5, 0, -1], scale = [1, 2, 0.5], rotate_y_deg = 30 }";
    let obj = scene_with(
        &[("m.obj", obj_text(&mesh).as_bytes())],
        &format!("obj = \"m.obj\"\n{transform}"),
    )
    .unwrap();
    for f in FORMATS {
        let ply = scene_with(
            &[("m.ply", &write(&mesh, f))],
            &format!("ply = \"m.ply\"\n{transform}"),
        )
        .unwrap();
        assert_eq!(ply.triangles.len(), 85, "{f:?}");
        assert!(ply.warnings.is_empty(), "{:?}", ply.warnings);
        assert!((0..85).all(|i| ply.attributes_of(i).n.is_some()));
        // tobj keeps the faces in order and fans polygons the same way.
        assert_eq!(ply.triangles, obj.triangles, "{f:?}");
        assert_eq!(ply.attributes, obj.attributes, "{f:?}");
    }
}

/// `face_normals = true` (Mitsuba's `face_normals`) drops the file's vertex normals on both
/// mesh formats, keeping the geometry; on other shapes it is refused with its line.
#[test]
fn face_normals_drop_the_vertex_normals() {
    let mesh = sample_mesh();
    let files: [(&str, Vec<u8>); 2] = [
        ("m.obj", obj_text(&mesh).into_bytes()),
        ("m.ply", write(&mesh, FORMATS[0])),
    ];
    for (name, bytes) in &files {
        let kind = &name[2..];
        let with = scene_with(&[(name, bytes)], &format!("{kind} = \"{name}\"")).unwrap();
        let normals = |s: &brdfwave::scene::Scene| {
            (0..s.triangles.len())
                .filter(|&i| s.attributes_of(i).n.is_some())
                .count()
        };
        assert_eq!(normals(&with), with.triangles.len(), "{name}");
        let flat = scene_with(
            &[(name, bytes)],
            &format!("{kind} = \"{name}\"\nface_normals = true"),
        )
        .unwrap();
        assert_eq!(normals(&flat), 0, "{name}");
        let strip = |s: &brdfwave::scene::Scene| -> Vec<[Vec3; 3]> {
            s.triangles.iter().map(|t| t.v).collect()
        };
        assert_eq!(strip(&with), strip(&flat), "{name}: the same geometry");
    }
    let err = scene_with(
        &[],
        "quads = [[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]]\nface_normals = true",
    )
    .unwrap_err();
    assert!(
        err.contains("s.toml:") && err.contains("face_normals applies only to obj and ply shapes"),
        "{err}"
    );
}

#[test]
fn ply_shape_errors_name_the_scene_line_and_the_file() {
    let e = scene_with(&[], "ply = \"missing.ply\"").unwrap_err();
    assert!(
        e.contains("s.toml:15: field 'shapes[0].ply': cannot read PLY file")
            && e.contains("missing.ply"),
        "{e}"
    );
    let bad = format!("{TRI_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n");
    let e = scene_with(&[("b.ply", bad.as_bytes())], "ply = \"b.ply\"").unwrap_err();
    assert!(
        e.contains("field 'shapes[0].ply': PLY file '")
            && e.contains("b.ply', line 13: vertex index 5"),
        "{e}"
    );
    let e = scene_with(
        &[("b.ply", bad.as_bytes())],
        "ply = \"b.ply\"\nobj = \"b.obj\"",
    )
    .unwrap_err();
    assert!(e.contains("has both obj and ply"), "{e}");
    // Zero-area faces are skipped with a warning; nothing usable left is an error that says why.
    let flat = format!("{TRI_HEADER}0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n");
    let e = scene_with(&[("f.ply", flat.as_bytes())], "ply = \"f.ply\"").unwrap_err();
    assert!(
        e.contains("skipped 1 zero-area triangle") && e.contains("no usable triangles"),
        "{e}"
    );
    let nan = format!("{TRI_HEADER}0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
    let e = scene_with(&[("n.ply", nan.as_bytes())], "ply = \"n.ply\"").unwrap_err();
    assert!(
        e.contains("vertex 2:") && e.contains("is not finite"),
        "{e}"
    );
}

/// Values that are finite as written but beyond single precision are refused where they are
/// (the positions, normals and texture coordinates become f32s: not `inf` later), in text and
/// in binary; and an
/// element that declares items but no properties is named as that, not as a truncated file.
#[test]
fn numbers_beyond_single_precision_and_empty_elements_are_named() {
    for (row, want) in [
        ("1 1e39 0", "line 11: 1e39 is out of the single-precision range (|x| <= 3.4e38) (element 'vertex' 1, property 'y')"),
        ("-4e38 0 0", "line 11: -4e38 is out of the single-precision range"),
        ("1 0 3.5e38", "line 11: 3.5e38 is out of the single-precision range"),
    ] {
        let text = format!("{TRI_HEADER}0 0 0\n{row}\n0 1 0\n3 0 1 2\n");
        let e = ply_error(text.as_bytes());
        assert!(e.contains(want), "{row}: {e}");
    }
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
    let mut b = header.as_bytes().to_vec();
    for x in [0.0f64, 1e39, 0.0] {
        b.extend(x.to_le_bytes());
    }
    let e = ply_error(&b);
    assert!(
        e.contains(&format!(
            "byte offset {}: 1e39 is out of the single-precision range",
            header.len() + 8
        )) && e.contains("property 'y'"),
        "{e}"
    );
    // A property the mesh does not keep may hold any double; one within single precision is
    // read.
    let extra = header.replace("end_header", "property double weight\nend_header");
    let mut b = extra.as_bytes().to_vec();
    for x in [0.0f64, 0.0, 0.0, 1e300] {
        b.extend(x.to_le_bytes());
    }
    parse(&b).unwrap();
    let mut ok = header.as_bytes().to_vec();
    for x in [0.0f64, 3e38, 0.0] {
        ok.extend(x.to_le_bytes());
    }
    assert_eq!(parse(&ok).unwrap().positions[0].y, 3e38);
    for (decl, count) in [
        ("element junk 5", 5u64),
        ("element junk 18446744073709551615", u64::MAX),
    ] {
        let text = format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{decl}\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
        );
        let e = ply_error(text.as_bytes());
        assert!(
            e.contains(&format!(
                "element 'junk' declares {count} elements but no properties"
            )) && !e.contains("truncated"),
            "{e}"
        );
    }
    // An element of no items and no properties is empty, and fine.
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement junk 0\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
    parse(text.as_bytes()).unwrap();
}
