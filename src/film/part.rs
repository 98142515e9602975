//! The partial-film file format (`.bwfilm`, described in the [`crate::film`] module
//! documentation): writing a film with its header, and reading it back checked.

use super::{Block, Film, Sums, Tile};
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

const MAGIC: &[u8; 8] = b"BWFILM\0\n";
/// Version 2 added `block_checksums`, version 3 `spp`.
const VERSION: u32 = 3;

/// The JSON header of a partial film (see the module documentation).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(
    deny_unknown_fields,
    expecting = "a partial film's header, a JSON object"
)]
pub struct PartHeader {
    /// The scene file as given on the command line (for messages only).
    pub scene: String,
    /// [`scene_hash`] of the scene as rendered (command-line overrides applied).
    pub scene_hash: String,
    /// [`code_version`] of the program that rendered it.
    pub code_version: String,
    /// `cpu` or `gpu`, and the device.
    pub backend: String,
    pub device: String,
    /// The whole image.
    pub width: u32,
    pub height: u32,
    pub tile: Tile,
    pub samples: [u32; 2],
    /// The samples per pixel of the whole render this part is a range of (`--spp`, else the
    /// scene's): the parts of a render hold 0..spp together.
    pub spp: u32,
    /// The sample range of each data block, in order.
    pub blocks: Vec<[u32; 2]>,
    pub extension_rays: u64,
    pub shadow_rays: u64,
    /// Non-finite values dropped, by stage (as in a render's summary).
    pub nonfinite_by_stage: Vec<(String, u64)>,
    pub seconds_render: f64,
    /// FNV-1a 64 of each data block's bytes, in hex (set by [`write_part`], checked on reading):
    /// a flipped bit in the body changed a pixel silently.
    #[serde(default)]
    pub block_checksums: Vec<String>,
}

/// The program's version for partial films: parts from different versions are not merged. The
/// package version and, when built from a git checkout, the commit, with `.modified-<hash>`
/// where the code had uncommitted changes (a hash of their diff: new files git does not track
/// are not seen). `brdfwave --version` prints it.
pub fn code_version() -> String {
    let (commit, modified) = (env!("BRDFWAVE_COMMIT"), env!("BRDFWAVE_MODIFIED"));
    match (commit.is_empty(), modified.is_empty()) {
        (true, _) => env!("CARGO_PKG_VERSION").to_string(),
        (false, true) => format!("{}+{}", env!("CARGO_PKG_VERSION"), commit),
        (false, false) => format!("{}+{}.{}", env!("CARGO_PKG_VERSION"), commit, modified),
    }
}

/// A hash of everything in the scene that the image depends on: camera, image size, integrator
/// settings but the sample count, materials, emitters, geometry and environment; not the file's
/// path or names, so the same scene loaded on two machines hashes the same. With the
/// `multijitter` sampler the size of its pattern counts too (the whole render's sample count,
/// or a batch's, [`crate::rng::pattern_bits`]), and so do a `sobol` render's batches: parts
/// drawn from different patterns are not one render.
pub fn scene_hash(s: &crate::scene::Scene) -> String {
    use std::fmt::Write as _;
    let mut h = crate::hash::Fnv64::new();
    let it = &s.integrator;
    let _ = write!(
        h,
        "{:?}|{}x{}|{} {} {} {} {}|{:?}|{:?}|{:?}|{:?}|",
        s.camera,
        s.width,
        s.height,
        it.max_depth,
        it.seed,
        it.russian_roulette,
        it.rr_start_depth,
        it.sampler,
        s.materials,
        s.emitters,
        s.spheres,
        s.environment
    );
    // Only a scene with a map adds it: every other scene keeps the hash it had.
    if let Some(m) = &s.environment_map {
        let _ = write!(h, "{m:?}|");
    }
    // Likewise hidden emitters.
    if it.hide_emitters {
        let _ = write!(h, "hide_emitters|");
    }
    hash_triangles(&mut h, s);
    // The patterns (multijitter) and batches (sobol in batches) the numbers depend on.
    if it.sampler == crate::rng::Sampler::Multijitter || it.batch_spp.is_some() {
        let _ = write!(h, "|pattern {}", it.pattern_bits());
    }
    format!("{:016x}", h.finish())
}

/// The triangles into the scene hash as the bits of their numbers: by far the largest part of a
/// big scene, where formatting them as text took 0.8 s for a million (a third of a
/// short render of the 1M-triangle bench scene). The destructuring makes a new field of
/// [`crate::scene::Triangle`] or [`crate::scene::VertexAttributes`] a compile error here, so
/// that it cannot be left out.
fn hash_triangles(h: &mut crate::hash::Fnv64, scene: &crate::scene::Scene) {
    let floats = |h: &mut crate::hash::Fnv64, xs: &[f32]| {
        for x in xs {
            h.bytes(&x.to_bits().to_le_bytes());
        }
    };
    h.u64(scene.triangles.len() as u64);
    for (i, t) in scene.triangles.iter().enumerate() {
        let crate::scene::Triangle {
            v,
            material,
            emitter,
        } = t;
        let crate::scene::VertexAttributes { n, uv } = scene.attributes_of(i);
        // Which optional attributes follow, then the numbers: positions, normals, uvs.
        h.bytes(&[n.is_some() as u8, uv.is_some() as u8]);
        for p in v.iter().chain(n.iter().flatten()) {
            floats(h, &p.to_array());
        }
        for q in uv.iter().flatten() {
            floats(h, &q.to_array());
        }
        h.bytes(&material.to_le_bytes());
        h.u64(emitter.map_or(u64::MAX, u64::from));
    }
}

/// A partial film read from or written to a file.
pub struct Part {
    pub header: PartHeader,
    pub film: Film,
}

impl Part {
    /// The partial film of a render of `scene` (loaded from `scene_file`) whose film is `film`
    /// and whose counts are in `out`.
    pub fn of_render(
        scene_file: &str,
        scene: &crate::scene::Scene,
        film: Film,
        out: &crate::output::RenderOutput,
        backend: &str,
        device: &str,
        seconds_render: f64,
    ) -> Part {
        let samples = film.samples();
        Part {
            header: PartHeader {
                scene: scene_file.to_string(),
                scene_hash: scene_hash(scene),
                code_version: code_version(),
                backend: backend.to_string(),
                device: device.to_string(),
                width: scene.width,
                height: scene.height,
                tile: film.tile,
                samples: [samples.start, samples.end],
                spp: scene.integrator.pattern_spp(),
                blocks: film
                    .blocks
                    .iter()
                    .map(|b| [b.samples.start, b.samples.end])
                    .collect(),
                extension_rays: out.extension_rays,
                shadow_rays: out.shadow_rays,
                nonfinite_by_stage: out.nonfinite_by_stage.clone(),
                seconds_render,
                block_checksums: Vec::new(),
            },
            film,
        }
    }
}

/// Writes `part` to `path` atomically.
pub fn write_part(path: &Path, part: &Part) -> Result<()> {
    let block_bytes: Vec<Vec<u8>> = part
        .film
        .blocks
        .iter()
        .map(|b| {
            b.sums
                .iter()
                .flatten()
                .flat_map(|v| v.to_le_bytes())
                .collect()
        })
        .collect();
    let mut header = part.header.clone();
    header.block_checksums = block_bytes.iter().map(|b| checksum(b)).collect();
    let json = serde_json::to_vec(&header)?;
    let mut bytes = Vec::with_capacity(
        16 + json.len() + 8 + part.film.blocks.len() * part.film.tile.pixels() * 48,
    );
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&VERSION.to_le_bytes());
    bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&json);
    while bytes.len() % 8 != 0 {
        bytes.push(0);
    }
    for b in &block_bytes {
        bytes.extend_from_slice(b);
    }
    crate::outfile::write(path, &bytes)?;
    Ok(())
}

/// The checksum of a data block's bytes in a partial film.
fn checksum(bytes: &[u8]) -> String {
    format!("{:016x}", crate::hash::Fnv64::new().bytes(bytes).finish())
}

/// Reads a partial film, checking that it is one and that its parts agree with each other.
pub fn read_part(path: &Path) -> Result<Part> {
    let shown = || crate::errors::shown_path(path);
    let bytes = crate::infile::read(path, crate::infile::FILM)
        .with_context(|| format!("{}: cannot read", shown()))?;
    parse_part(&bytes).with_context(shown)
}

/// Reads only the header of a partial film (checked as [`read_part`] checks it, the length of
/// the data included), not its sums.
pub fn read_header(path: &Path) -> Result<PartHeader> {
    use std::io::Read as _;
    let at = || crate::errors::shown_path(path);
    let (mut f, len) = crate::infile::open(path, crate::infile::FILM)
        .with_context(|| format!("{}: cannot read", at()))?;
    let mut head = vec![0u8; 16.min(len as usize)];
    f.read_exact(&mut head).with_context(at)?;
    if head.len() == 16 && &head[..8] == MAGIC {
        let n = u32::from_le_bytes(head[12..16].try_into().expect("4 bytes")) as u64;
        let mut rest = vec![0u8; n.min(len.saturating_sub(16)) as usize];
        f.read_exact(&mut rest).with_context(at)?;
        head.extend(rest);
    }
    Ok(parse_header(&head, len).with_context(at)?.0)
}

/// The header of a partial film from the file's first bytes (at least up to the end of the
/// header) and its length; and where the data starts.
fn parse_header(bytes: &[u8], file_len: u64) -> Result<(PartHeader, usize)> {
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        bail!("not a brdfwave partial film (it does not start with the BWFILM mark)");
    }
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let version = word(8);
    if version != VERSION {
        bail!("partial-film format version {version}; this program reads version {VERSION}");
    }
    let n = word(12) as usize;
    let json = bytes
        .get(16..16 + n)
        .context("the file ends inside its header")?;
    let header: PartHeader =
        serde_json::from_slice(json).context("the header is not a valid partial-film header")?;
    let h = &header;
    // Header text is printed to the terminal (merge's summary and messages): no control
    // characters, which could move the cursor or recolour it.
    for (field, text) in [
        ("scene", &h.scene),
        ("scene_hash", &h.scene_hash),
        ("code_version", &h.code_version),
        ("backend", &h.backend),
        ("device", &h.device),
    ] {
        if text.chars().any(|c| c.is_control()) {
            bail!("header field '{field}': {text:?} holds control characters");
        }
    }
    let max = crate::conventions::MAX_FILM_SIZE;
    if h.width == 0 || h.height == 0 || h.width > max || h.height > max {
        bail!(
            "header fields 'width' and 'height': {}x{} is not an image size (1 to {max} per side)",
            h.width,
            h.height
        );
    }
    h.tile
        .check_within(h.width, h.height)
        .map_err(anyhow::Error::msg)
        .context("header field 'tile'")?;
    let [s0, s1] = h.samples;
    if s0 >= s1 {
        bail!("header field 'samples': {s0}..{s1} holds no samples");
    }
    let mut next = s0;
    for (i, b) in h.blocks.iter().enumerate() {
        if b[0] != next || b[1] <= b[0] {
            bail!(
                "header field 'blocks': block {i} is {}..{}, but should start at {next} and be non-empty",
                b[0],
                b[1]
            );
        }
        next = b[1];
    }
    if next != s1 {
        bail!(
            "header field 'blocks': the blocks end at {next}, not at the end of 'samples' ({s1})"
        );
    }
    if h.block_checksums.len() != h.blocks.len() {
        bail!(
            "header field 'block_checksums': {} checksum(s) for {} block(s)",
            h.block_checksums.len(),
            h.blocks.len()
        );
    }
    let start = (16 + n).div_ceil(8) * 8;
    let expected = h.blocks.len() as u64 * h.tile.pixels() as u64 * 48;
    let found = file_len.saturating_sub(start as u64);
    if found != expected {
        bail!(
            "the data holds {found} bytes, but {} block(s) of a {}x{} tile need {expected}",
            h.blocks.len(),
            h.tile.width,
            h.tile.height
        );
    }
    Ok((header, start))
}

fn parse_part(bytes: &[u8]) -> Result<Part> {
    let (header, start) = parse_header(bytes, bytes.len() as u64)?;
    let h = &header;
    let pixels = h.tile.pixels();
    let mut values = bytes[start..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")));
    let mut blocks = Vec::with_capacity(h.blocks.len());
    for (i, b) in h.blocks.iter().enumerate() {
        // n samples of finite f32 radiance add up to at most n·f32::MAX, their squares to
        // n·f32::MAX²: a larger sum (1e300 passed as "finite") made an infinite pixel.
        let n = (b[1] - b[0]) as f64;
        let max = f32::MAX as f64;
        let bounds = [n * max, n * max * max];
        let mut sums = Vec::with_capacity(pixels);
        for p in 0..pixels {
            let s: Sums = std::array::from_fn(|_| values.next().expect("length checked"));
            if !s.iter().all(|v| v.is_finite() && *v >= 0.0) {
                bail!(
                    "block {i}, pixel {p} of the tile: sums {s:?} are not finite and non-negative"
                );
            }
            if (0..6).any(|c| s[c] > bounds[c / 3]) {
                bail!(
                    "block {i}, pixel {p} of the tile: sums {s:?} are larger than {} samples of finite radiance can add up to",
                    b[1] - b[0]
                );
            }
            sums.push(s);
        }
        let from = start + i * pixels * 48;
        if checksum(&bytes[from..from + pixels * 48]) != h.block_checksums[i] {
            bail!("block {i}: its data does not match its checksum: the file is damaged");
        }
        blocks.push(Block {
            samples: b[0]..b[1],
            sums,
        });
    }
    Ok(Part {
        film: Film {
            tile: header.tile,
            blocks,
        },
        header,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a triangle reaches the scene hash (they are hashed as bits, not text).
    #[test]
    fn the_scene_hash_sees_every_triangle_field() {
        let path = std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/scenes/cornell-box.toml"
        ));
        let text = std::fs::read_to_string(path).unwrap();
        let base = crate::scene::load_str(&text, path).unwrap();
        let h0 = scene_hash(&base);
        assert_eq!(h0, scene_hash(&base.clone()), "not deterministic");
        // Each change is made to the first emitting triangle (with index i).
        type Change = dyn Fn(&mut crate::scene::Scene, usize);
        let changed: [&Change; 6] = [
            &|s, i| s.triangles[i].v[2].y = f32::from_bits(s.triangles[i].v[2].y.to_bits() ^ 1),
            &|s, i| attributes(s, i).n = Some([glam::Vec3::Y; 3]),
            &|s, i| attributes(s, i).uv = Some([glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y]),
            &|s, i| s.triangles[i].material += 1,
            &|s, i| s.triangles[i].emitter = Some(s.triangles[i].emitter.map_or(0, |e| e + 1)),
            &|s, i| s.triangles[i].emitter = None,
        ];
        fn attributes(
            s: &mut crate::scene::Scene,
            i: usize,
        ) -> &mut crate::scene::VertexAttributes {
            s.attributes.resize(s.triangles.len(), Default::default());
            &mut s.attributes[i]
        }
        for (k, change) in changed.iter().enumerate() {
            let mut s = base.clone();
            let i = s
                .triangles
                .iter()
                .position(|t| t.emitter.is_some())
                .unwrap();
            change(&mut s, i);
            assert_ne!(scene_hash(&s), h0, "change {k} is not seen");
        }
        // Attributes that say "none" hash as absent ones: the same scene either way.
        let mut padded = base.clone();
        attributes(&mut padded, 0);
        assert_eq!(
            scene_hash(&padded),
            h0,
            "explicit empty attributes change the hash"
        );
        let mut fewer = base.clone();
        fewer.triangles.pop();
        assert_ne!(scene_hash(&fewer), h0, "a dropped triangle is not seen");
    }

    #[test]
    fn a_part_survives_the_file_format_and_damage_is_refused() {
        let header = PartHeader {
            scene: "s.toml".into(),
            scene_hash: "00".into(),
            code_version: code_version(),
            backend: "cpu".into(),
            device: "test".into(),
            width: 4,
            height: 3,
            tile: Tile {
                x: 1,
                y: 1,
                width: 2,
                height: 2,
            },
            samples: [2, 5],
            spp: 8,
            blocks: vec![[2, 4], [4, 5]],
            extension_rays: 7,
            shadow_rays: 3,
            nonfinite_by_stage: vec![("extend".into(), 0)],
            seconds_render: 0.5,
            block_checksums: Vec::new(),
        };
        let film = Film {
            tile: header.tile,
            blocks: vec![
                Block {
                    samples: 2..4,
                    sums: (0..4).map(|i| [i as f64 + 0.1; 6]).collect(),
                },
                Block {
                    samples: 4..5,
                    sums: (0..4).map(|i| [i as f64 * 1e38; 6]).collect(),
                },
            ],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.bwfilm");
        write_part(
            &path,
            &Part {
                header,
                film: film.clone(),
            },
        )
        .unwrap();
        let back = read_part(&path).unwrap();
        assert_eq!(back.film, film);
        assert_eq!(back.header.block_checksums.len(), 2);
        let bytes = std::fs::read(&path).unwrap();
        let err = |b: &[u8]| format!("{:#}", parse_part(b).err().expect("refused"));
        assert!(err(&bytes[..bytes.len() - 8]).contains("data holds"));
        assert!(err(&bytes[..20]).contains("header"));
        assert!(err(b"P6\n4 4\n255\n........").contains("not a brdfwave partial film"));
        let mut bad = bytes.clone();
        let last = bad.len() - 8;
        bad[last..].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(err(&bad).contains("not finite"));
        // A sum no finite f32 samples can make (one sample: at most f32::MAX).
        bad[last..].copy_from_slice(&1e300f64.to_le_bytes());
        assert!(err(&bad).contains("larger than 1 samples"), "{}", err(&bad));
        // One flipped bit of a plausible value: only the checksum sees it.
        let mut flipped = bytes.clone();
        flipped[last] ^= 1;
        assert!(err(&flipped).contains("checksum"), "{}", err(&flipped));
    }
}
