//! The PLY reader (and a small writer, for round-trip tests and exports): Turk's polygon file
//! format in its three encodings, `ascii`, `binary_little_endian` and `binary_big_endian`.
//!
//! What is read: the `vertex` element's `x y z` (required), `nx ny nz` (optional, all three or
//! none: the per-vertex shading normals) and `u v` / `s t` / `texture_u texture_v` (optional
//! texture coordinates), and the `face` element's `vertex_indices` (or `vertex_index`) list;
//! polygons are fan-triangulated. Every other element and property is read over and ignored.
//! All eight scalar types (`char`/`int8` … `double`/`float64`) are accepted for every property
//! and as list counts.
//!
//! No crate is used: `ply-rs` (the only maintained-looking one) has had no release since 2020,
//! reads every element into a map of named properties, reports errors without a position, and
//! allocates what the header declares. This reader checks each declared element count against
//! the bytes that follow the header before it allocates anything (a header that declares 10⁹
//! vertices in a 1 kB file is refused at once), and every error names where it is: the header
//! line, the line of an ASCII value, or the byte offset of a binary one, with the element and
//! its index. It never panics.

use glam::{Vec2, Vec3};

/// The encoding of the data after the header.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

impl Format {
    fn name(self) -> &'static str {
        match self {
            Format::Ascii => "ascii",
            Format::BinaryLittleEndian => "binary_little_endian",
            Format::BinaryBigEndian => "binary_big_endian",
        }
    }
}

/// A PLY mesh: positions, optional per-vertex normals and texture coordinates, and polygons
/// (each at least three vertex indices, all in range).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlyMesh {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub faces: Vec<Vec<u32>>,
}

impl PlyMesh {
    /// The triangles of the polygons, fan-triangulated: `(f0, fk, fk+1)`.
    pub fn triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.faces
            .iter()
            .flat_map(|f| (1..f.len() - 1).map(move |k| [f[0], f[k], f[k + 1]]))
    }
}

/// The scalar types of PLY, each with its two names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    fn is_float(self) -> bool {
        matches!(self, Scalar::F32 | Scalar::F64)
    }
    /// The range of an integer type.
    fn range(self) -> (f64, f64) {
        match self {
            Scalar::I8 => (i8::MIN as f64, i8::MAX as f64),
            Scalar::U8 => (0.0, u8::MAX as f64),
            Scalar::I16 => (i16::MIN as f64, i16::MAX as f64),
            Scalar::U16 => (0.0, u16::MAX as f64),
            Scalar::I32 => (i32::MIN as f64, i32::MAX as f64),
            Scalar::U32 => (0.0, u32::MAX as f64),
            Scalar::F32 | Scalar::F64 => (f64::NEG_INFINITY, f64::INFINITY),
        }
    }
    fn decode(self, b: &[u8], big: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big {
                    <$t>::from_be_bytes(a) as f64
                } else {
                    <$t>::from_le_bytes(a) as f64
                }
            }};
        }
        match self {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => get!(i16, 2),
            Scalar::U16 => get!(u16, 2),
            Scalar::I32 => get!(i32, 4),
            Scalar::U32 => get!(u32, 4),
            Scalar::F32 => get!(f32, 4),
            Scalar::F64 => get!(f64, 8),
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// The count type of a list property.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

impl Element {
    /// The fewest bytes one element takes in the data: binary, the fixed sizes and the list
    /// counts; ASCII, one character and one separator per value.
    fn min_bytes(&self, format: Format) -> u64 {
        self.props
            .iter()
            .map(|p| match (format, p.list) {
                (Format::Ascii, _) => 2,
                (_, Some(c)) => c.size() as u64,
                (_, None) => p.ty.size() as u64,
            })
            .sum()
    }
    fn find(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the data.
    data: usize,
    /// Lines in the header (the first data line of an ASCII file is `lines + 1`).
    lines: usize,
}

fn header(bytes: &[u8]) -> Result<Header, String> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut pos = 0usize;
    let mut line_no = 0usize;
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(format!(
                "header line {}: the header ends without 'end_header'",
                line_no + 1
            ));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        line_no += 1;
        let at = |msg: String| format!("header line {line_no}: {msg}");
        let line = std::str::from_utf8(raw)
            .map_err(|_| at("the header is not ASCII text".into()))?
            .trim_end_matches('\r');
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line != "ply" {
                return Err(at("a PLY file starts with the line 'ply'".into()));
            }
            continue;
        }
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, version] => {
                if format.is_some() {
                    return Err(at("a second 'format' line".into()));
                }
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLittleEndian,
                    "binary_big_endian" => Format::BinaryBigEndian,
                    _ => {
                        return Err(at(format!(
                            "unknown format '{f}': expected ascii, binary_little_endian or binary_big_endian"
                        )))
                    }
                });
                if *version != "1.0" {
                    return Err(at(format!("unsupported version '{version}': expected 1.0")));
                }
            }
            ["element", name, count] => {
                let count: u64 = count
                    .parse()
                    .map_err(|_| at(format!("element '{name}': '{count}' is not a count")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            ["property", rest @ ..] => {
                let Some(e) = elements.last_mut() else {
                    return Err(at("a property before any 'element' line".into()));
                };
                let ty = |s: &str| {
                    Scalar::parse(s).ok_or_else(|| {
                        at(format!(
                            "unknown type '{s}': expected one of char uchar short ushort int uint \
                             float double (or int8 … float64)"
                        ))
                    })
                };
                let p = match rest {
                    ["list", c, t, name] => {
                        let list = ty(c)?;
                        if list.is_float() {
                            return Err(at(format!("list '{name}': the count type '{c}' is not an integer type")));
                        }
                        Property {
                            name: name.to_string(),
                            list: Some(list),
                            ty: ty(t)?,
                        }
                    }
                    [t, name] => Property {
                        name: name.to_string(),
                        list: None,
                        ty: ty(t)?,
                    },
                    _ => {
                        return Err(at(format!(
                            "'{line}': expected 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'"
                        )))
                    }
                };
                if e.find(&p.name).is_some() {
                    return Err(at(format!(
                        "element '{}' has two properties '{}'",
                        e.name, p.name
                    )));
                }
                e.props.push(p);
            }
            ["end_header"] => break,
            _ => return Err(at(format!("'{line}' is not a PLY header line"))),
        }
    }
    let Some(format) = format else {
        return Err("the header has no 'format' line".into());
    };
    Ok(Header {
        format,
        elements,
        data: pos,
        lines: line_no,
    })
}

/// Where the values come from: ASCII tokens with their lines, or binary bytes.
enum Source<'a> {
    Ascii {
        tokens: std::iter::Peekable<Box<dyn Iterator<Item = (usize, &'a str)> + 'a>>,
        last_line: usize,
    },
    Binary {
        bytes: &'a [u8],
        pos: usize,
        big: bool,
    },
}

impl<'a> Source<'a> {
    fn new(bytes: &'a [u8], h: &Header) -> Result<Source<'a>, String> {
        let data = &bytes[h.data..];
        Ok(match h.format {
            Format::Ascii => {
                let text = std::str::from_utf8(data).map_err(|e| {
                    let line = h.lines
                        + 1
                        + data[..e.valid_up_to()]
                            .iter()
                            .filter(|&&b| b == b'\n')
                            .count();
                    format!("line {line}: the ASCII data is not text")
                })?;
                let first = h.lines + 1;
                let it: Box<dyn Iterator<Item = (usize, &str)>> = Box::new(
                    text.lines()
                        .enumerate()
                        .flat_map(move |(l, s)| s.split_whitespace().map(move |t| (first + l, t))),
                );
                Source::Ascii {
                    tokens: it.peekable(),
                    last_line: h.lines,
                }
            }
            _ => Source::Binary {
                bytes,
                pos: h.data,
                big: h.format == Format::BinaryBigEndian,
            },
        })
    }

    /// Where the next value is, for messages.
    fn here(&mut self) -> String {
        match self {
            Source::Ascii { tokens, last_line } => {
                let l = tokens.peek().map_or(*last_line, |t| t.0);
                format!("line {l}")
            }
            Source::Binary { pos, .. } => format!("byte offset {pos}"),
        }
    }

    /// The next value of type `ty`, or why not.
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        let x = match self {
            Source::Ascii { tokens, last_line } => {
                let Some((l, t)) = tokens.next() else {
                    return Err("the data ends (truncated file)".into());
                };
                *last_line = l;
                let x: f64 = if ty.is_float() {
                    t.parse().map_err(|_| format!("'{t}' is not a number"))?
                } else {
                    t.parse::<i64>()
                        .map_err(|_| format!("'{t}' is not an integer"))? as f64
                };
                let (lo, hi) = ty.range();
                if !ty.is_float() && !(lo..=hi).contains(&x) {
                    return Err(format!("{t} is out of the range of its type"));
                }
                x
            }
            Source::Binary { bytes, pos, big } => {
                let n = ty.size();
                let Some(b) = bytes.get(*pos..*pos + n) else {
                    return Err(format!(
                        "the data ends (truncated file of {} bytes)",
                        bytes.len()
                    ));
                };
                *pos += n;
                ty.decode(b, *big)
            }
        };
        Ok(x)
    }

    /// Data left after the last element.
    fn rest(&mut self) -> Option<String> {
        match self {
            Source::Ascii { tokens, .. } => tokens
                .next()
                .map(|(l, t)| format!("line {l}: '{t}' follows the last element")),
            Source::Binary { bytes, pos, .. } => (*pos < bytes.len()).then(|| {
                format!(
                    "byte offset {pos}: {} byte(s) follow the last element",
                    bytes.len() - *pos
                )
            }),
        }
    }
}

/// Which vertex properties hold what.
struct VertexLayout {
    xyz: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
}

fn vertex_layout(e: &Element) -> Result<VertexLayout, String> {
    let scalar = |n: &str| {
        e.find(n)
            .filter(|&i| e.props[i].list.is_none())
            .ok_or_else(|| n.to_string())
    };
    let all3 = |a: &str, b: &str, c: &str| -> Result<Option<[usize; 3]>, String> {
        match (scalar(a), scalar(b), scalar(c)) {
            (Ok(x), Ok(y), Ok(z)) => Ok(Some([x, y, z])),
            (Err(_), Err(_), Err(_)) => Ok(None),
            _ => Err(format!(
                "element 'vertex' has only some of the properties {a} {b} {c} (give all three or none)"
            )),
        }
    };
    let xyz =
        all3("x", "y", "z")?.ok_or("element 'vertex' has no properties x y z (the positions)")?;
    let normal = all3("nx", "ny", "nz")?;
    let uv = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")]
        .iter()
        .find_map(|(a, b)| Some([scalar(a).ok()?, scalar(b).ok()?]));
    Ok(VertexLayout { xyz, normal, uv })
}

/// Parse a PLY file. The error names the place: `line N: …` (the header, or a value of an
/// ASCII file) or `byte offset N: …` (a binary value), and the element and its index.
pub fn parse(bytes: &[u8]) -> Result<PlyMesh, String> {
    let h = header(bytes)?;
    // An ASCII file's last value may lack its separator.
    let mut left = (bytes.len() - h.data) as u64 + u64::from(h.format == Format::Ascii);
    for e in &h.elements {
        if e.props.is_empty() && e.count > 0 {
            return Err(format!(
                "element '{}' declares {} elements but no properties: an element without \
                 properties holds nothing (a property line missing from the header?)",
                crate::errors::excerpt(&e.name),
                e.count
            ));
        }
        let min = e.min_bytes(h.format).max(1);
        if e.count.saturating_mul(min) > left {
            return Err(format!(
                "element '{}' declares {} elements of at least {min} byte(s) each, but only {left} \
                 byte(s) of data follow the header (a wrong count or a truncated file)",
                e.name, e.count
            ));
        }
        left -= e.count * min;
    }
    let vertex = h.elements.iter().position(|e| e.name == "vertex");
    let face = h.elements.iter().position(|e| e.name == "face");
    let Some(vertex) = vertex else {
        return Err("the header declares no 'vertex' element".into());
    };
    let layout = vertex_layout(&h.elements[vertex])?;
    let indices = match face {
        Some(f) => {
            let e = &h.elements[f];
            let i = e
                .find("vertex_indices")
                .or_else(|| e.find("vertex_index"))
                .ok_or("element 'face' has no list property vertex_indices (or vertex_index)")?;
            if e.props[i].list.is_none() || e.props[i].ty.is_float() {
                return Err(format!(
                    "element 'face': '{}' must be a list of an integer type",
                    e.props[i].name
                ));
            }
            Some(i)
        }
        None => None,
    };

    let nverts = h.elements[vertex].count as usize;
    let mut mesh = PlyMesh {
        positions: Vec::with_capacity(nverts),
        normals: layout.normal.map(|_| Vec::with_capacity(nverts)),
        uvs: layout.uv.map(|_| Vec::with_capacity(nverts)),
        faces: Vec::new(),
    };
    let mut src = Source::new(bytes, &h)?;
    // The vertex properties the mesh keeps.
    let used: Vec<usize> = layout
        .xyz
        .iter()
        .chain(layout.normal.iter().flatten())
        .chain(layout.uv.iter().flatten())
        .copied()
        .collect();
    let mut values: Vec<f64> = Vec::new();
    for (ei, e) in h.elements.iter().enumerate() {
        if Some(ei) == face {
            mesh.faces.reserve(e.count as usize);
        }
        for k in 0..e.count {
            values.clear();
            let mut list: Vec<u32> = Vec::new();
            for (pi, p) in e.props.iter().enumerate() {
                let at = |loc: String, m: String| {
                    format!(
                        "{loc}: {m} (element '{}' {k}, property '{}')",
                        e.name, p.name
                    )
                };
                let Some(ct) = p.list else {
                    let loc = src.here();
                    let x = src.value(p.ty).map_err(|m| at(loc.clone(), m))?;
                    // A value the mesh keeps becomes single precision: one beyond it is
                    // refused here, where it is, not found as `inf` later.
                    if ei == vertex && used.contains(&pi) && x.is_finite() {
                        crate::numbers::f32_of(x).map_err(|m| at(loc, m))?;
                    }
                    values.push(x);
                    continue;
                };
                values.push(f64::NAN);
                let loc = src.here();
                let n = src.value(ct).map_err(|m| at(loc.clone(), m))?;
                if n < 0.0 {
                    return Err(at(loc, format!("negative list length {n}")));
                }
                let keep = Some(ei) == face && Some(pi) == indices;
                if keep && n < 3.0 {
                    let msg = format!("a face needs at least 3 vertices, found {n}");
                    return Err(at(loc, msg));
                }
                for _ in 0..n as u64 {
                    let loc = src.here();
                    let x = src.value(p.ty).map_err(|m| at(loc.clone(), m))?;
                    if keep {
                        if !(x >= 0.0 && x < nverts as f64) {
                            let msg = format!(
                                "vertex index {x} does not exist ({nverts} vertices, indices start at 0)"
                            );
                            return Err(at(loc, msg));
                        }
                        list.push(x as u32);
                    }
                }
            }
            if ei == vertex {
                let v = |i: [usize; 3]| {
                    Vec3::new(
                        values[i[0]] as f32,
                        values[i[1]] as f32,
                        values[i[2]] as f32,
                    )
                };
                mesh.positions.push(v(layout.xyz));
                if let (Some(n), Some(out)) = (layout.normal, mesh.normals.as_mut()) {
                    out.push(v(n));
                }
                if let (Some(t), Some(out)) = (layout.uv, mesh.uvs.as_mut()) {
                    out.push(Vec2::new(values[t[0]] as f32, values[t[1]] as f32));
                }
            } else if Some(ei) == face {
                mesh.faces.push(list);
            }
        }
    }
    if let Some(msg) = src.rest() {
        return Err(format!(
            "{msg}: the data is longer than the header's element counts say"
        ));
    }
    Ok(mesh)
}

/// Write `mesh` as a PLY file: `vertex` with `x y z` (and `nx ny nz`, `u v` when present) as
/// `float`, `face` with `vertex_indices` as a `uchar`-counted list of `int` (or of `ushort`
/// counts when a face has more than 255 vertices).
pub fn write(mesh: &PlyMesh, format: Format) -> Vec<u8> {
    let big_faces = mesh.faces.iter().any(|f| f.len() > 255);
    let count_ty = if big_faces { "ushort" } else { "uchar" };
    let mut out = format!(
        "ply\nformat {} 1.0\ncomment written by brdfwave\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n",
        format.name(),
        mesh.positions.len()
    );
    if mesh.normals.is_some() {
        out.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.uvs.is_some() {
        out.push_str("property float u\nproperty float v\n");
    }
    out.push_str(&format!(
        "element face {}\nproperty list {count_ty} int vertex_indices\nend_header\n",
        mesh.faces.len()
    ));
    let mut out = out.into_bytes();
    let vertex_values = |i: usize| {
        let mut v = mesh.positions[i].to_array().to_vec();
        if let Some(n) = &mesh.normals {
            v.extend(n[i].to_array());
        }
        if let Some(t) = &mesh.uvs {
            v.extend(t[i].to_array());
        }
        v
    };
    let big = format == Format::BinaryBigEndian;
    for i in 0..mesh.positions.len() {
        let vals = vertex_values(i);
        if format == Format::Ascii {
            let s: Vec<String> = vals.iter().map(|x| format!("{x:?}")).collect();
            out.extend(format!("{}\n", s.join(" ")).bytes());
        } else {
            for x in vals {
                out.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
        }
    }
    for f in &mesh.faces {
        if format == Format::Ascii {
            let s: Vec<String> = f.iter().map(|x| x.to_string()).collect();
            out.extend(format!("{} {}\n", f.len(), s.join(" ")).bytes());
            continue;
        }
        if big_faces {
            let n = f.len() as u16;
            out.extend(if big {
                n.to_be_bytes()
            } else {
                n.to_le_bytes()
            });
        } else {
            out.push(f.len() as u8);
        }
        for &x in f {
            let x = x as i32;
            out.extend(if big {
                x.to_be_bytes()
            } else {
                x.to_le_bytes()
            });
        }
    }
    out
}
