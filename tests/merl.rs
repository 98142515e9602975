//! The MERL `.binary` reader, writer and lookup (`brdfwave::measured::merl`), on synthetic files
//! only: written by our writer from analytic models, or byte by byte for the bad files.

use brdfwave::brdf::inline::parse_inline;
use brdfwave::brdf::Brdf;
use brdfwave::measured::merl::{
    cell_centre, cell_index, directions, MerlTable, CELLS, FILE_BYTES, SCALE,
};
use brdfwave::rng::random_f32;
use glam::Vec3;
use std::path::{Path, PathBuf};

fn brdf(src: &str) -> std::sync::Arc<dyn Brdf> {
    parse_inline(src).unwrap().brdf
}

fn ward() -> std::sync::Arc<dyn Brdf> {
    brdf(r#"model = "ward", kd = [0.2, 0.3, 0.1], ks = [0.3, 0.25, 0.2], alpha_x = 0.15"#)
}

/// A file with this header and these raw (unscaled) values, in `dir`.
fn raw_file(dir: &Path, name: &str, dims: [i32; 3], values: &[f64]) -> PathBuf {
    let mut bytes = Vec::new();
    for d in dims {
        bytes.extend_from_slice(&d.to_le_bytes());
    }
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn read_err(p: &Path) -> String {
    let e = MerlTable::read(p).unwrap_err().to_string();
    assert!(e.contains(&p.display().to_string()), "names the file: {e}");
    e
}

/// A uniformly distributed direction in the upper hemisphere up to `max_theta` degrees.
fn direction(seed: u32, i: u32, max_theta: f32) -> Vec3 {
    let zmin = max_theta.to_radians().cos();
    let z = 1.0 - random_f32(seed, i, 0, 0, 0) * (1.0 - zmin);
    let phi = 2.0 * std::f32::consts::PI * random_f32(seed, i, 0, 0, 1);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn written_file_reads_back_bit_for_bit_and_matches_the_model_at_cell_centres() {
    let dir = tempfile::tempdir().unwrap();
    let m = ward();
    let table = MerlTable::from_brdf(m.as_ref());
    let path = dir.path().join("ward.binary");
    table.write(&path).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), FILE_BYTES);
    let back = MerlTable::read(&path).unwrap();
    assert_eq!(
        back, table,
        "the f32 table survives the f64 file and its scales"
    );
    // Below-horizon cells are written missing, and counted on reading.
    assert!(back.missing() > 0 && back.missing() % 3 == 0);
    let mut worst = 0.0f32;
    for ih in (0..90).step_by(7) {
        for id in (0..90).step_by(5) {
            for ip in (0..180).step_by(11) {
                let (wi, wo) = {
                    let (th, td, pd) = cell_centre(ih, id, ip);
                    directions(th, td, pd)
                };
                if wi.z < 0.2 || wo.z < 0.2 {
                    continue;
                }
                let (f, g) = (m.eval(wi, wo), back.lookup(wi, wo));
                let rel = ((f - g).abs() / f.max(Vec3::splat(1e-3))).max_element();
                worst = worst.max(rel);
            }
        }
    }
    assert!(worst < 5e-3, "worst relative error at cell centres {worst}");
}

#[test]
fn lookup_between_cell_centres_is_within_interpolation_error() {
    let m = brdf(
        r#"model = "cook_torrance", kd = 0.2, ks = 0.5, roughness = 0.3, normalization = "walter""#,
    );
    let table = MerlTable::from_brdf(m.as_ref());
    let mut errs: Vec<f32> = (0..4000)
        .map(|i| {
            let (wi, wo) = (direction(7, 2 * i, 75.0), direction(7, 2 * i + 1, 75.0));
            let (f, g) = (m.eval(wi, wo).x, table.lookup(wi, wo).x);
            (f - g).abs() / f.max(1e-3)
        })
        .collect();
    errs.sort_by(f32::total_cmp);
    let (median, p99) = (errs[errs.len() / 2], errs[errs.len() * 99 / 100]);
    assert!(
        median < 0.005 && p99 < 0.05,
        "median {median}, 99th percentile {p99}"
    );
}

#[test]
fn lookup_is_reciprocal() {
    let table = MerlTable::from_brdf(ward().as_ref());
    for i in 0..2000 {
        let (wi, wo) = (direction(3, 2 * i, 89.0), direction(3, 2 * i + 1, 89.0));
        let (a, b) = (table.lookup(wi, wo), table.lookup(wo, wi));
        assert!(
            (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1e-3),
            "{wi} {wo}: {a} {b}"
        );
    }
    assert_eq!(table.lookup(Vec3::Z, Vec3::new(0.0, 0.6, -0.8)), Vec3::ZERO);
}

#[test]
fn layout_scales_and_index_mapping_follow_the_reference_reader() {
    // Raw value = 1000·ih + id + φd index / 1000 in every plane; at a cell centre the lookup
    // returns its own label times the channel's scale, which checks the √θh index, the plane
    // order (φd fastest) and the scales together.
    let dir = tempfile::tempdir().unwrap();
    let mut raw = vec![0.0f64; 3 * CELLS];
    for ih in 0..90 {
        for id in 0..90 {
            for ip in 0..180 {
                let label = 1000.0 * ih as f64 + id as f64 + ip as f64 / 1000.0;
                for c in 0..3 {
                    raw[c * CELLS + ((ih * 90 + id) * 180 + ip)] = label;
                }
            }
        }
    }
    let t = MerlTable::read(&raw_file(dir.path(), "l.binary", [90, 90, 180], &raw)).unwrap();
    for (ih, id, ip) in [(0, 3, 7), (12, 45, 90), (44, 10, 170), (80, 2, 1)] {
        // θh from the index as the reference reader defines it: ih = ⌊√(θh/(π/2)·90·90)⌋.
        let t_h = (ih as f64 + 0.5) / 90.0;
        let theta_h = t_h * t_h * std::f64::consts::FRAC_PI_2;
        let theta_d = (id as f64 + 0.5) / 90.0 * std::f64::consts::FRAC_PI_2;
        let phi_d = (ip as f64 + 0.5) / 180.0 * std::f64::consts::PI;
        let g = t.lookup_angles(theta_h as f32, theta_d as f32, phi_d as f32);
        let label = 1000.0 * ih as f64 + id as f64 + ip as f64 / 1000.0;
        for c in 0..3 {
            let want = label * SCALE[c];
            assert!(
                (g[c] as f64 - want).abs() < 1e-5 * want + 1e-4,
                "cell {ih},{id},{ip} channel {c}: {} vs {want}",
                g[c]
            );
        }
        // φd and φd + π are one cell (reciprocity).
        let h = t.lookup_angles(
            theta_h as f32,
            theta_d as f32,
            (phi_d + std::f64::consts::PI) as f32 - std::f32::consts::PI,
        );
        assert!((g - h).abs().max_element() < 1e-3 * g.max_element());
    }
    assert_eq!(cell_index(1, 2, 3), 3 + 180 * (2 + 90));
}

#[test]
fn negative_entries_are_missing_counted_and_left_out_of_the_interpolation() {
    let dir = tempfile::tempdir().unwrap();
    let mut raw = vec![1500.0f64; 3 * CELLS];
    // One red cell missing: its neighbours' value (1 sr⁻¹) is used in its place.
    let hole = cell_index(40, 40, 90);
    raw[hole] = -1.0;
    // A whole θh row of green missing: nothing to interpolate from, so 0.
    for id in 0..90 {
        for ip in 0..180 {
            raw[CELLS + cell_index(89, id, ip)] = -2.5;
        }
    }
    let t = MerlTable::read(&raw_file(dir.path(), "m.binary", [90, 90, 180], &raw)).unwrap();
    assert_eq!(t.missing(), 1 + 90 * 180);
    let (th, td, pd) = cell_centre(40, 40, 90);
    let v = t.lookup_angles(th, td, pd);
    assert!((v.x - 1.0).abs() < 1e-6 && (v.y - 1.15).abs() < 1e-5, "{v}");
    assert_eq!(t.cell(40, 40, 90)[0], None);
    let (th, td, pd) = cell_centre(89, 10, 10);
    let v = t.lookup_angles(th + 0.01, td, pd);
    assert_eq!(v.y, 0.0);
    assert!((v.z - 1.66).abs() < 1e-5, "{v}");
}

#[test]
fn bad_files_are_refused_with_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = vec![1.0f64; 3 * CELLS];
    // Wrong dimensions, even with the right product (the reference reader's only check).
    let e = read_err(&raw_file(d, "dims.binary", [180, 90, 90], &good));
    assert!(
        e.contains("180 × 90 × 90") && e.contains("90 (θh) × 90 (θd) × 180 (φd)"),
        "{e}"
    );
    // A huge declared size is refused from the header alone (the file is 12 bytes).
    let e = read_err(&raw_file(d, "huge.binary", [i32::MAX, i32::MAX, 1000], &[]));
    assert!(e.contains("2147483647 × 2147483647 × 1000"), "{e}");
    let e = read_err(&raw_file(d, "neg.binary", [-90, 90, 180], &good));
    assert!(e.contains("-90 × 90 × 180"), "{e}");
    // Truncated: the bytes missing are named.
    let e = read_err(&raw_file(d, "short.binary", [90, 90, 180], &good[..CELLS]));
    assert!(
        e.contains("truncated") && e.contains(&format!("{} bytes are missing", 16 * CELLS)),
        "{e}"
    );
    let p = d.join("tiny.binary");
    std::fs::write(&p, [90u8, 0, 0, 0, 90]).unwrap();
    let e = read_err(&p);
    assert!(
        e.contains("truncated: 5 bytes") && e.contains("12-byte header"),
        "{e}"
    );
    // Too long.
    let mut long = good.clone();
    long.push(0.0);
    let e = read_err(&raw_file(d, "long.binary", [90, 90, 180], &long));
    assert!(e.contains("8 bytes follow the three planes"), "{e}");
    // A value that is not a number.
    let mut nan = good.clone();
    nan[2 * CELLS + cell_index(3, 4, 5)] = f64::NAN;
    let e = read_err(&raw_file(d, "nan.binary", [90, 90, 180], &nan));
    assert!(
        e.contains("not finite") && e.contains("blue plane, cell θh 3, θd 4, φd 5"),
        "{e}"
    );
    let e = read_err(&d.join("absent.binary"));
    assert!(e.contains("cannot open"), "{e}");
    let e = read_err(d);
    assert!(e.contains("is a directory"), "{e}");
}

/// A value finite in the file but beyond single precision once scaled (each plane by its own
/// scale) is refused naming the value, the plane and the cell, never loaded as inf (which
/// evaluated to NaN, plotted as `inf` and dropped samples in a render); the largest value that
/// fits loads. Devices and FIFOs are refused as what they are.
#[test]
fn values_that_overflow_once_scaled_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let limit = |plane: usize| f32::MAX as f64 / SCALE[plane];
    for (plane, name) in [(0, "red"), (1, "green"), (2, "blue")] {
        for (over, v) in [
            (false, limit(plane) * 0.999),
            (true, limit(plane) * 1.001),
            (true, 1e300),
        ] {
            let mut values = vec![0.5f64; 3 * CELLS];
            values[plane * CELLS + cell_index(7, 8, 9)] = v;
            let p = raw_file(
                d,
                &format!("p{plane}-{over}.binary"),
                [90, 90, 180],
                &values,
            );
            if !over {
                let t = MerlTable::read(&p).unwrap();
                assert!(t.cell(7, 8, 9)[plane].unwrap().is_finite());
                continue;
            }
            let e = read_err(&p);
            assert!(
                e.contains("is out of the single-precision range")
                    && e.contains(&format!("{name} plane, cell θh 7, θd 8, φd 9"))
                    && !e.contains("inf"),
                "{name} {v}: {e}"
            );
        }
    }
    for dev in ["/dev/zero", "/dev/urandom"] {
        let e = MerlTable::read(Path::new(dev)).unwrap_err().to_string();
        assert!(e.contains("character device, not a regular file"), "{e}");
    }
}
