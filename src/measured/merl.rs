//! The MERL BRDF database's `.binary` format (Matusik, Pfister, Brand and McMillan 2003, "A
//! data-driven reflectance model"): reading with strict validation, writing synthetic files from
//! an analytic model, and the interpolated lookup f_r(wi, wo).
//!
//! **Layout**, checked against the database's reference reader (`BRDFRead.cpp`, distributed by
//! MERL with the data; its `read_brdf`, `lookup_brdf_val` and the three `*_index` functions):
//! * a header of three little-endian `int32`: the dimensions 90 (θh) × 90 (θd) × 180 (φd) —
//!   the reference reader checks only their product, 1 458 000; we require the three values
//!   themselves, so a file of another resolution is refused rather than misread;
//! * then three planes (red, green, blue) of 1 458 000 little-endian `float64` each, and nothing
//!   after them: a file is exactly 12 + 3·1 458 000·8 = 34 992 012 bytes;
//! * within a plane the cell (ih, id, ip) is at `ip + 180·(id + 90·ih)` (φd fastest);
//! * a stored value times the channel's scale is f_r in sr⁻¹ (without the cosine): red 1/1500,
//!   green 1.15/1500, blue 1.66/1500 ([`SCALE`]);
//! * the θh index is non-linear, ih = ⌊√(θh/(π/2))·90⌋, which puts most cells near the specular
//!   peak; id = ⌊θd/(π/2)·90⌋; ip = ⌊φd/π·180⌋ after folding φd into [0, π) by reciprocity
//!   (swapping wi and wo turns φd into φd + π), all clamped to the table;
//! * θh, θd, φd are Rusinkiewicz's (1998) half/difference angles: h = normalize(wi + wo), and d
//!   is wi rotated by −φh about the normal, then by −θh about the bitangent; wi is the light
//!   direction (the reference reader's "in"). Isotropy drops φh. (The reference reader takes
//!   θ = acos(z) in double precision; in f32 that loses the first θh cells, so we take
//!   atan2(√(x² + y²), z).)
//! * negative values mark cells that were not measured (the reference reader prints "Below
//!   horizon." for them): they are counted ([`MerlTable::missing`]) and left out of the
//!   interpolation.
//!
//! **Validation** ([`MerlTable::read`]): the header is read first and must declare 90 × 90 × 180
//! (any other, a huge one included, is refused before anything is allocated); then the file's
//! size must be exactly 34 992 012 bytes (a shorter file is reported as truncated with the bytes
//! missing, a longer one with the bytes in excess); every value must be finite. Every message
//! names the file.
//!
//! **Lookup** ([`MerlTable::lookup`]): where the reference reader takes the cell the angles
//! fall in, we interpolate trilinearly between cell centres in the index coordinates (the √θh
//! coordinate for θh), clamping at the ends of θh and θd and wrapping φd around its period π, so
//! the lookup is continuous and exact at cell centres ([`cell_centre`]). Missing corners are
//! left out and the weights of the others renormalised, per channel; a point whose eight corners
//! are all missing is 0. The table holds f32 (what the GPU reads), and the geometry is f32.
//!
//! **Writing** ([`MerlTable::from_brdf`], [`MerlTable::write`]): the model is evaluated at every
//! cell centre; cells with either direction at or below the horizon are written as −1 (missing),
//! as measured files mark them.

use crate::brdf::Brdf;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::{FRAC_PI_2, PI};
use std::io::Read as _;
use std::path::{Path, PathBuf};

/// Cells along θh, θd and φd.
pub const THETA_H: usize = 90;
pub const THETA_D: usize = 90;
pub const PHI_D: usize = 180;
/// Cells in one colour plane.
pub const CELLS: usize = THETA_H * THETA_D * PHI_D;
/// Stored value × scale = f_r, per channel (red, green, blue), as in the reference reader.
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// Header bytes: three int32 dimensions.
pub const HEADER_BYTES: u64 = 12;
/// The exact size of a MERL file.
pub const FILE_BYTES: u64 = HEADER_BYTES + 3 * CELLS as u64 * 8;
/// The value a writer stores for a cell that has no measurement.
const MISSING_RAW: f64 = -1.0;

/// A MERL file that cannot be read: the file and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {what}", path.display())]
pub struct MerlError {
    pub path: PathBuf,
    pub what: String,
}

/// A measured isotropic BRDF on the MERL grid, as f_r in sr⁻¹ (the channel scales applied);
/// a negative value is a missing cell.
#[derive(Clone, Debug, PartialEq)]
pub struct MerlTable {
    /// Three planes (red, green, blue) of [`CELLS`] values, in the file's order.
    values: Vec<f32>,
    missing: usize,
}

/// The index of cell (ih, id, ip) within a plane.
pub fn cell_index(ih: usize, id: usize, ip: usize) -> usize {
    ip + PHI_D * (id + THETA_D * ih)
}

/// The angles (θh, θd, φd) of the centre of cell (ih, id, ip): the point the continuous index
/// coordinates of [`MerlTable::lookup`] put at (ih, id, ip) exactly.
pub fn cell_centre(ih: usize, id: usize, ip: usize) -> (f32, f32, f32) {
    let t = (ih as f32 + 0.5) / THETA_H as f32;
    (
        t * t * FRAC_PI_2,
        (id as f32 + 0.5) / THETA_D as f32 * FRAC_PI_2,
        (ip as f32 + 0.5) / PHI_D as f32 * PI,
    )
}

/// The direction pair (wi toward the light, wo toward the viewer, local frame) with half and
/// difference angles (θh, θd, φd) and φh = 0: the inverse of [`half_diff`].
pub fn directions(theta_h: f32, theta_d: f32, phi_d: f32) -> (Vec3, Vec3) {
    let (sd, cd) = theta_d.sin_cos();
    let d = Vec3::new(sd * phi_d.cos(), sd * phi_d.sin(), cd);
    let (sh, ch) = theta_h.sin_cos();
    // d rotated by +θh about the bitangent (y).
    let wi = Vec3::new(d.x * ch + d.z * sh, d.y, d.z * ch - d.x * sh);
    let h = Vec3::new(sh, 0.0, ch);
    let wo = 2.0 * wi.dot(h) * h - wi;
    (wi, wo)
}

/// Rusinkiewicz's half and difference angles (θh, θd, φd) of a direction pair, φd folded into
/// [0, π) by reciprocity; `None` when wi + wo has no direction.
pub fn half_diff(wi: Vec3, wo: Vec3) -> Option<(f32, f32, f32)> {
    let sum = wi + wo;
    let len2 = sum.length_squared();
    if len2 <= 1e-20 {
        return None;
    }
    let h = sum / len2.sqrt();
    // atan2 of the sine and cosine, not acos: acos(cos θ) loses θ below ~3e-4 rad in f32,
    // which is the first cells of the √θh axis.
    let theta_h = h.x.hypot(h.y).atan2(h.z);
    let phi_h = h.y.atan2(h.x);
    let (sp, cp) = phi_h.sin_cos();
    // wi rotated by −φh about the normal, then by −θh about the bitangent.
    let t = Vec3::new(wi.x * cp + wi.y * sp, wi.y * cp - wi.x * sp, wi.z);
    let (st, ct) = theta_h.sin_cos();
    let d = Vec3::new(t.x * ct - t.z * st, t.y, t.z * ct + t.x * st);
    let theta_d = d.x.hypot(d.y).atan2(d.z);
    let mut phi_d = d.y.atan2(d.x);
    if phi_d < 0.0 {
        phi_d += PI;
    }
    Some((theta_h, theta_d, phi_d))
}

/// The continuous index coordinates of (θh, θd, φd): cell centres at whole numbers.
fn index_coords(theta_h: f32, theta_d: f32, phi_d: f32) -> [f32; 3] {
    [
        (theta_h.max(0.0) / FRAC_PI_2).sqrt() * THETA_H as f32 - 0.5,
        theta_d / FRAC_PI_2 * THETA_D as f32 - 0.5,
        phi_d / PI * PHI_D as f32 - 0.5,
    ]
}

/// The two cells and the weight of the second along a clamped axis of `n` cells.
fn clamped_axis(x: f32, n: usize) -> ([usize; 2], f32) {
    let x = x.clamp(0.0, (n - 1) as f32);
    let i = (x.floor() as usize).min(n - 2);
    ([i, i + 1], x - i as f32)
}

/// The two cells and the weight of the second along the periodic φd axis.
fn periodic_axis(x: f32, n: usize) -> ([usize; 2], f32) {
    let f = x.floor();
    let i = (f as i64).rem_euclid(n as i64) as usize;
    ([i, (i + 1) % n], (x - f).clamp(0.0, 1.0))
}

fn err(path: &Path, what: impl Into<String>) -> MerlError {
    MerlError {
        path: path.to_path_buf(),
        what: what.into(),
    }
}

impl MerlTable {
    /// Reads and validates a MERL `.binary` file (see the module documentation).
    pub fn read(path: &Path) -> Result<MerlTable, MerlError> {
        let io = |what: &str, e: std::io::Error| err(path, format!("{what}: {e}"));
        // A regular file of at most the limit (a device or a FIFO is refused, not read).
        let (mut file, len) =
            crate::infile::open(path, crate::infile::MEASURED).map_err(|e| io("cannot open", e))?;
        if len < HEADER_BYTES {
            return Err(err(
                path,
                format!(
                    "truncated: {len} bytes, shorter than the 12-byte header of a MERL file \
                     (three int32 dimensions)"
                ),
            ));
        }
        let mut header = [0u8; HEADER_BYTES as usize];
        file.read_exact(&mut header)
            .map_err(|e| io("cannot read the header", e))?;
        Self::check_header(path, &header)?;
        Self::check_size(path, len)?;
        let mut body = vec![0u8; (FILE_BYTES - HEADER_BYTES) as usize];
        file.read_exact(&mut body).map_err(|e| {
            io(
                "cannot read the three planes (did the file change while being read?)",
                e,
            )
        })?;
        Self::decode(path, &body)
    }

    /// The header must declare 90 × 90 × 180.
    fn check_header(path: &Path, header: &[u8; 12]) -> Result<(), MerlError> {
        let dim = |k: usize| i32::from_le_bytes(header[4 * k..4 * k + 4].try_into().unwrap());
        let dims = [dim(0), dim(1), dim(2)];
        if dims != [THETA_H as i32, THETA_D as i32, PHI_D as i32] {
            // In i128: three i32 multiply to at most 2^93.
            let declared = match dims.iter().all(|&d| d > 0) {
                true => {
                    let n = dims.iter().map(|&d| d as i128).product::<i128>();
                    format!("{n} values per plane")
                }
                false => "a dimension that is not positive".to_string(),
            };
            return Err(err(
                path,
                format!(
                    "the header declares dimensions {} × {} × {} ({declared}); \
                     a MERL file is 90 (θh) × 90 (θd) × 180 (φd), and no other resolution is \
                     read",
                    dims[0], dims[1], dims[2]
                ),
            ));
        }
        Ok(())
    }

    /// The file must be exactly [`FILE_BYTES`] long.
    fn check_size(path: &Path, len: u64) -> Result<(), MerlError> {
        let layout = "12-byte header + 3 planes of 1458000 float64";
        match len.cmp(&FILE_BYTES) {
            std::cmp::Ordering::Less => Err(err(
                path,
                format!(
                    "truncated: {len} bytes, a 90 × 90 × 180 MERL file has {FILE_BYTES} \
                     ({layout}); {} bytes are missing",
                    FILE_BYTES - len
                ),
            )),
            std::cmp::Ordering::Greater => Err(err(
                path,
                format!(
                    "{len} bytes, a 90 × 90 × 180 MERL file has {FILE_BYTES} ({layout}): {} \
                     bytes follow the three planes",
                    len - FILE_BYTES
                ),
            )),
            std::cmp::Ordering::Equal => Ok(()),
        }
    }

    /// The three planes (without the header) to the table.
    fn decode(path: &Path, body: &[u8]) -> Result<MerlTable, MerlError> {
        let mut values = Vec::with_capacity(3 * CELLS);
        let mut missing = 0;
        for (k, raw) in body.chunks_exact(8).enumerate() {
            let v = f64::from_le_bytes(raw.try_into().unwrap());
            let (channel, cell) = (k / CELLS, k % CELLS);
            if !v.is_finite() {
                let (ih, rest) = (cell / (THETA_D * PHI_D), cell % (THETA_D * PHI_D));
                return Err(err(
                    path,
                    format!(
                        "value {v} is not finite ({} plane, cell θh {ih}, θd {}, φd {})",
                        ["red", "green", "blue"][channel],
                        rest / PHI_D,
                        rest % PHI_D
                    ),
                ));
            }
            if v < 0.0 {
                missing += 1;
                values.push(-1.0);
            } else {
                // Finite in the file but beyond single precision once scaled: refused here, not
                // loaded as inf (which evaluated to NaN and rendered as dropped samples).
                let scaled = crate::numbers::f32_of(v * SCALE[channel]).map_err(|e| {
                    let (ih, rest) = (cell / (THETA_D * PHI_D), cell % (THETA_D * PHI_D));
                    err(
                        path,
                        format!(
                            "value {} scaled by MERL's {}: {e} ({} plane, cell θh {ih}, θd {}, \
                             φd {})",
                            crate::brdf::params::fmt_num(v),
                            ["1/1500", "1.15/1500", "1.66/1500"][channel],
                            ["red", "green", "blue"][channel],
                            rest / PHI_D,
                            rest % PHI_D
                        ),
                    )
                })?;
                values.push(scaled);
            }
        }
        Ok(MerlTable { values, missing })
    }

    /// The table of an analytic model, sampled at every cell centre; cells with a direction at
    /// or below the horizon are missing.
    pub fn from_brdf(b: &dyn Brdf) -> MerlTable {
        let cells: Vec<Option<Vec3>> = (0..CELLS)
            .into_par_iter()
            .map(|cell| {
                let (ih, rest) = (cell / (THETA_D * PHI_D), cell % (THETA_D * PHI_D));
                let (th, td, pd) = cell_centre(ih, rest / PHI_D, rest % PHI_D);
                let (wi, wo) = directions(th, td, pd);
                (wi.z > 0.0 && wo.z > 0.0).then(|| b.eval(wi, wo))
            })
            .collect();
        let mut values = vec![0.0f32; 3 * CELLS];
        let mut missing = 0;
        for (cell, f) in cells.iter().enumerate() {
            for c in 0..3 {
                values[c * CELLS + cell] = match f {
                    Some(f) => f[c].max(0.0),
                    None => {
                        missing += 1;
                        -1.0
                    }
                };
            }
        }
        MerlTable { values, missing }
    }

    /// The file's bytes: header, then the three planes with the channel scales divided out.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(FILE_BYTES as usize);
        for d in [THETA_H, THETA_D, PHI_D] {
            out.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for (k, &v) in self.values.iter().enumerate() {
            let raw = if v < 0.0 {
                MISSING_RAW
            } else {
                v as f64 / SCALE[k / CELLS]
            };
            out.extend_from_slice(&raw.to_le_bytes());
        }
        out
    }

    /// Writes the table as a MERL file, atomically.
    pub fn write(&self, path: &Path) -> Result<(), crate::outfile::WriteError> {
        crate::outfile::write(path, &self.to_bytes())
    }

    /// Number of missing values (over the three planes).
    pub fn missing(&self) -> usize {
        self.missing
    }

    /// Bytes the table holds (f32 values).
    pub fn memory_bytes(&self) -> usize {
        self.values.len() * std::mem::size_of::<f32>()
    }

    /// The three planes in the file's order, f_r with the scales applied; negative = missing.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Applies `f(channel, cell index, value)` to every value that is not missing (tests add
    /// measurement-like noise this way); results are clamped to ≥ 0.
    pub fn map_values(&mut self, mut f: impl FnMut(usize, usize, f32) -> f32) {
        for (k, v) in self.values.iter_mut().enumerate() {
            if *v >= 0.0 {
                let y = f(k / CELLS, k % CELLS, *v);
                *v = if y.is_finite() { y.max(0.0) } else { 0.0 };
            }
        }
    }

    /// The value of cell (ih, id, ip): `None` in a channel that is missing.
    pub fn cell(&self, ih: usize, id: usize, ip: usize) -> [Option<f32>; 3] {
        let i = cell_index(ih, id, ip);
        [0, 1, 2].map(|c| Some(self.values[c * CELLS + i]).filter(|v| *v >= 0.0))
    }

    /// f_r(wi, wo) in sr⁻¹ without the cosine, trilinearly interpolated (module documentation);
    /// 0 below either horizon.
    pub fn lookup(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let Some((th, td, pd)) = half_diff(wi, wo) else {
            return Vec3::ZERO;
        };
        self.lookup_angles(th, td, pd)
    }

    /// The interpolated value at half/difference angles (θh, θd, φd).
    pub fn lookup_angles(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> Vec3 {
        let [x, y, z] = index_coords(theta_h, theta_d, phi_d);
        let (ih, fh) = clamped_axis(x, THETA_H);
        let (id, fd) = clamped_axis(y, THETA_D);
        let (ip, fp) = periodic_axis(z, PHI_D);
        let mut sum = [0.0f32; 3];
        let mut weight = [0.0f32; 3];
        for (a, wa) in [(ih[0], 1.0 - fh), (ih[1], fh)] {
            for (b, wb) in [(id[0], 1.0 - fd), (id[1], fd)] {
                for (p, wp) in [(ip[0], 1.0 - fp), (ip[1], fp)] {
                    let w = wa * wb * wp;
                    let i = cell_index(a, b, p);
                    for c in 0..3 {
                        let v = self.values[c * CELLS + i];
                        if v >= 0.0 {
                            sum[c] += w * v;
                            weight[c] += w;
                        }
                    }
                }
            }
        }
        Vec3::from_array([0, 1, 2].map(|c| {
            if weight[c] > 1e-6 {
                sum[c] / weight[c]
            } else {
                0.0
            }
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_diff_inverts_directions_at_cell_centres() {
        for (ih, id, ip) in [(0, 0, 0), (10, 40, 100), (60, 20, 179), (89, 5, 45)] {
            let (th, td, pd) = cell_centre(ih, id, ip);
            let (wi, wo) = directions(th, td, pd);
            let (a, b, c) = half_diff(wi, wo).unwrap();
            assert!((a - th).abs() < 2e-4, "θh {a} {th}");
            assert!((b - td).abs() < 2e-4, "θd {b} {td}");
            // φd is meaningless at θd = 0; elsewhere it comes back (mod π).
            let dp = (c - pd).rem_euclid(PI);
            assert!(dp.min(PI - dp) < 2e-3 / td.sin().max(1e-3), "φd {c} {pd}");
            let [x, y, _] = index_coords(a, b, c);
            assert!((x - ih as f32).abs() < 2e-2 && (y - id as f32).abs() < 2e-3);
        }
    }

    #[test]
    fn swapping_the_directions_adds_pi_to_phi_d() {
        let (wi, wo) = directions(0.3, 0.7, 0.4);
        let (_, _, a) = half_diff(wi, wo).unwrap();
        let (_, _, b) = half_diff(wo, wi).unwrap();
        let d = (a - b).rem_euclid(PI);
        assert!(d.min(PI - d) < 1e-4, "{a} {b}");
    }

    #[test]
    fn periodic_axis_wraps_and_clamped_axis_clamps() {
        assert_eq!(periodic_axis(-0.25, 180), ([179, 0], 0.75));
        assert_eq!(periodic_axis(179.5, 180), ([179, 0], 0.5));
        assert_eq!(clamped_axis(-3.0, 90), ([0, 1], 0.0));
        assert_eq!(clamped_axis(89.7, 90), ([88, 89], 1.0));
    }

    /// Dimensions that multiply past i64, or are negative, are named as they are, without a
    /// wrapped product (a build with overflow checks would panic on it).
    #[test]
    fn a_header_of_other_dimensions_is_refused_with_its_product() {
        let header = |d: [i32; 3]| {
            let mut h = [0u8; 12];
            for (k, v) in d.iter().enumerate() {
                h[4 * k..4 * k + 4].copy_from_slice(&v.to_le_bytes());
            }
            h
        };
        let msg = |d| {
            let e = MerlTable::check_header(Path::new("m.binary"), &header(d)).unwrap_err();
            e.to_string()
        };
        let big = msg([1 << 30; 3]);
        assert!(
            big.contains("(1237940039285380274899124224 values per plane)"),
            "{big}"
        );
        let neg = msg([-1, 90, 180]);
        assert!(neg.contains("(a dimension that is not positive)"), "{neg}");
        assert!(msg([90, 90, 181]).contains("(1466100 values per plane)"));
        assert!(MerlTable::check_header(Path::new("m"), &header([90, 90, 180])).is_ok());
    }
}
