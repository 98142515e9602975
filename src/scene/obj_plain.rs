//! A parallel reader for the common shape of a big OBJ file: vertex positions (`v x y z`),
//! faces of vertex indices (`f 1 2 3`, polygons too), comments, blank lines, smoothing groups,
//! and object or group names before the first face. For such a file it gives what tobj gives
//! ([`super::obj`] reads with `triangulate` and `single_index`): one model with the same name,
//! and faces whose vertices are the same numbers (parsed by the same `f32::from_str`), in the
//! same order, polygons split into the same fans. Its vertex list keeps the file's order where
//! tobj's keeps the order of first use; the triangles do not differ.
//!
//! Anything else (texture coordinates, normals, materials, points, lines, a name after a face, a
//! negative index, a malformed number or index, a number that is not finite in single
//! precision, an index to a later vertex, text that is not ASCII) makes it decline, and the general reader (the line checks of
//! [`super::obj::scan_obj`], then tobj) reads the file, with its messages naming the line.

use rayon::prelude::*;

/// Texts shorter than this are read in one piece.
const PIECE_BYTES: usize = 1 << 20;

/// The vertices and triangle indices (from 0) of one piece of the text.
#[derive(Default)]
struct Piece {
    positions: Vec<f32>,
    indices: Vec<u32>,
    /// The largest `index - (vertices of this piece before its line)` of its faces: the file
    /// is valid when this is at most the vertices of the pieces before it.
    reach: i64,
    /// The name of an `o` or `g` line of this piece (tobj's rule), and whether a face precedes
    /// it in the piece.
    name: Option<(String, bool)>,
}

/// Chars that `str::split_whitespace` splits ASCII text at.
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | 0x0b | 0x0c | b'\r')
}

fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|&b| is_space(b)).filter(|w| !w.is_empty())
}

/// tobj's model name of an `o` or `g` line: the line after its first char, trimmed.
fn object_name(line: &[u8]) -> String {
    // ASCII, so every byte is a char.
    let name = String::from_utf8_lossy(&line[1..]).trim().to_string();
    if name.is_empty() {
        "unnamed_object".to_string()
    } else {
        name
    }
}

/// Reads one piece (whole lines); None when it holds anything this reader leaves to tobj.
fn read_piece(text: &[u8]) -> Option<Piece> {
    let mut p = Piece::default();
    let mut face = Vec::new();
    for line in text.split(|&b| b == b'\n') {
        let mut w = words(line);
        match w.next() {
            None => {}
            Some(b"v") => {
                for _ in 0..3 {
                    let x = std::str::from_utf8(w.next()?).ok()?;
                    let x = x.parse::<f32>().ok()?;
                    // Not finite (or beyond single precision as written): the general reader
                    // names the line.
                    if !x.is_finite() {
                        return None;
                    }
                    p.positions.push(x);
                }
                if w.next().is_some() {
                    return None;
                }
            }
            Some(b"f") => {
                let before = (p.positions.len() / 3) as i64;
                face.clear();
                for word in w {
                    let i: u32 = std::str::from_utf8(word).ok()?.parse().ok()?;
                    if i == 0 {
                        return None;
                    }
                    p.reach = p.reach.max(i as i64 - before);
                    face.push(i - 1);
                }
                if face.len() < 3 {
                    return None;
                }
                // tobj's fans: (a, b, c), (a, c, d), ...
                for k in 1..face.len() - 1 {
                    p.indices.extend([face[0], face[k], face[k + 1]]);
                }
            }
            Some(b"o" | b"g") => p.name = Some((object_name(line), !p.indices.is_empty())),
            Some(b"s") => {}
            Some(w) if w[0] == b'#' => {}
            Some(_) => return None,
        }
    }
    Some(p)
}

/// The text cut into about `n` pieces of whole lines.
fn pieces(text: &[u8], n: usize) -> Vec<&[u8]> {
    let mut out = Vec::with_capacity(n);
    let mut start = 0;
    for k in 1..n {
        let want = (text.len() * k / n).max(start);
        let Some(nl) = text[want..].iter().position(|&b| b == b'\n') else {
            break;
        };
        let end = want + nl + 1;
        out.push(&text[start..end]);
        start = end;
    }
    out.push(&text[start..]);
    out
}

/// tobj's model of `text` when it has the plain form this reader handles, else None.
pub(super) fn read_plain(text: &str) -> Option<tobj::Model> {
    if !text.is_ascii() {
        return None;
    }
    let n = (text.len() / PIECE_BYTES).clamp(1, 4 * rayon::current_num_threads());
    // A piece that declines stops the others early (the file then goes to tobj).
    let read: Vec<Piece> = pieces(text.as_bytes(), n)
        .into_par_iter()
        .map(read_piece)
        .collect::<Option<_>>()?;
    let mut name = "unnamed_object".to_string();
    let mut seen_faces = false;
    let mut vertices = 0i64;
    for p in &read {
        if let Some((n, after_face)) = &p.name {
            // A name after a face starts a second model: left to tobj.
            if seen_faces || *after_face {
                return None;
            }
            name = n.clone();
        }
        if p.reach > vertices {
            return None;
        }
        vertices += (p.positions.len() / 3) as i64;
        seen_faces |= !p.indices.is_empty();
    }
    if !seen_faces {
        return None;
    }
    let mut mesh = tobj::Mesh {
        positions: Vec::with_capacity(read.iter().map(|p| p.positions.len()).sum()),
        indices: Vec::with_capacity(read.iter().map(|p| p.indices.len()).sum()),
        ..Default::default()
    };
    for p in read {
        mesh.positions.extend_from_slice(&p.positions);
        mesh.indices.extend_from_slice(&p.indices);
    }
    Some(tobj::Model::new(mesh, name))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// tobj's triangles of `text`, as vertex triples.
    fn tobj_triangles(text: &str) -> (String, Vec<[f32; 9]>) {
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ignore_points: true,
            ignore_lines: true,
        };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
            Err(tobj::LoadError::OpenFileFailed)
        })
        .unwrap();
        assert_eq!(models.len(), 1);
        (models[0].name.clone(), triangles(&models[0]))
    }

    fn triangles(m: &tobj::Model) -> Vec<[f32; 9]> {
        let p = &m.mesh.positions;
        m.mesh
            .indices
            .chunks_exact(3)
            .map(|f| std::array::from_fn(|k| p[3 * f[k / 3] as usize + k % 3]))
            .collect()
    }

    #[test]
    fn plain_files_read_as_tobj_reads_them() {
        let texts = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "# c\n\no  my thing \r\nv 0 0 0\r\nv 1.5 0 0\r\nv 0 1e-3 0\r\nv 1 1 0.1\r\ns off\nf 1 2 3 4\nf 4 3 +2\n",
            "  g   \nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 5 4 3 2 1\n#x\nf 1 3 2",
            "v 1 2 3\nv\t4 5 6 \nv 7\x0b8\x0c9\nf 3 1 2\n",
        ];
        for text in texts {
            let plain = read_plain(text).expect(text);
            let (name, tris) = tobj_triangles(text);
            assert_eq!(plain.name, name, "{text:?}");
            let ours = triangles(&plain);
            assert_eq!(ours.len(), tris.len());
            for (a, b) in ours.iter().zip(&tris) {
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{text:?}");
            }
        }
    }

    #[test]
    fn other_files_are_left_to_tobj() {
        for text in [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/2 3/3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            "v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 x\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nf 1 2 3\n",
            "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
            "v 0 0 0\u{a0}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        ] {
            assert!(read_plain(text).is_none(), "{text:?}");
        }
    }

    /// A text cut into many pieces reads as in one piece (names, the vertex count of the
    /// pieces before a face's).
    #[test]
    fn pieces_join_up() {
        let mut text = String::from("o big\n");
        for i in 0..2000 {
            text += &format!("v {i} {} 0.25\nv {i}.5 1 2\n", i % 7);
            if i > 0 {
                text += &format!("f {} {} {}\n", 2 * i - 1, 2 * i + 2, 2 * i);
            }
        }
        let whole = read_piece(text.as_bytes()).unwrap();
        for n in [2, 3, 17, 64] {
            let ps: Vec<Piece> = pieces(text.as_bytes(), n)
                .into_iter()
                .map(|p| read_piece(p).unwrap())
                .collect();
            let ind: Vec<u32> = ps.iter().flat_map(|p| p.indices.clone()).collect();
            assert_eq!(ind, whole.indices);
        }
        let (name, tris) = tobj_triangles(&text);
        let plain = read_plain(&text).unwrap();
        assert_eq!(plain.name, name);
        assert_eq!(triangles(&plain), tris);
        // A face reaching a vertex of a later line is left to tobj's checks.
        assert!(read_plain(&(text.clone() + "f 1 2 4001\nv 0 0 0\n")).is_none());
    }
}
