//! `brdfwave brdf plot`: every kind written as PNG and SVG with its CSV beside it; the CSV
//! holds the BRDF's values (a Lambert material's f is albedo/π, its albedo the albedo); the PNG
//! has its size and drawn pixels in the plot area; overlaid materials are named in the SVG's
//! legend; bad kinds and extensions are clear errors.

mod common;
use std::path::Path;
use std::process::{Command, Output};

const LAMBERT: &str = r#"model = "lambert", albedo = 0.5"#;
const WARD: &str = r#"model = "ward", kd = 0.1, ks = 0.8, alpha_x = 0.2, alpha_y = 0.1"#;

fn plot(kind: &str, out: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .args(["brdf", "plot", "--kind", kind, "--theta-i", "30"])
        .args(["--material", LAMBERT, "--material", WARD])
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .expect("run brdfwave")
}

/// The CSV's rows as numbers (an empty field is NaN), after its header.
fn csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| {
            // The header's labels are quoted; the rows are plain numbers.
            l.split(',')
                .map(|f| f.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (vec![header], rows)
}

#[test]
fn every_kind_writes_png_svg_and_the_brdf_values_as_csv() {
    let dir = tempfile::tempdir().unwrap();
    let expected_rows = [
        ("polar", 361),
        ("slice", 90 * 90),
        ("albedo", 45),
        ("hemisphere", 96 * 96),
    ];
    for (kind, rows) in expected_rows {
        for ext in ["png", "svg"] {
            let out = dir.path().join(format!("{kind}.{ext}"));
            let o = plot(kind, &out, &[]);
            assert!(
                o.status.success(),
                "{kind}.{ext}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let (header, data) = csv(&out.with_extension("csv"));
            assert_eq!(data.len(), rows, "{kind}: rows");
            assert!(header[0].contains("albedo = 0.5") && header[0].contains("model = ward"));
            // The Lambert column (the first value column after the coordinates).
            let col = if matches!(kind, "slice" | "hemisphere") {
                2
            } else {
                1
            };
            let lambert: Vec<f64> = data
                .iter()
                .map(|r| r[col])
                .filter(|v| !v.is_nan())
                .collect();
            assert!(!lambert.is_empty());
            for v in lambert {
                let want = match kind {
                    "albedo" => 0.5,
                    "hemisphere" => continue, // f·cosθo, checked below
                    _ => 0.5 / std::f64::consts::PI,
                };
                // The ends of the polar plot lie on the horizon, where f is 0 by definition.
                if kind == "polar" && v == 0.0 {
                    continue;
                }
                assert!((v - want).abs() < 2e-3 * want, "{kind}: {v} vs {want}");
            }
            if kind == "hemisphere" {
                // f·cosθo = albedo/π · z, z from the cell's (x, y).
                for r in &data {
                    if r[2].is_nan() {
                        continue;
                    }
                    let z = (1.0 - r[0] * r[0] - r[1] * r[1]).sqrt();
                    let want = 0.5 / std::f64::consts::PI * z;
                    assert!((r[2] - want).abs() < 1e-5, "{r:?} vs {want}");
                }
            }
            match ext {
                "png" => {
                    check_png(&out);
                    let size = image::image_dimensions(&out).unwrap();
                    let want = if matches!(kind, "polar" | "albedo") {
                        (960, 600)
                    } else {
                        (980, 480)
                    };
                    assert_eq!(size, want, "{kind}");
                }
                _ => check_svg(&out, kind),
            }
        }
    }
}

/// The PNG has the figure's size and, in its middle, pixels that are not the white background.
fn check_png(path: &Path) {
    let img = image::open(path).unwrap().to_rgb8();
    assert!(
        img.width() >= 500 && img.height() >= 450,
        "{:?}",
        img.dimensions()
    );
    let (w, h) = img.dimensions();
    let mut drawn = 0;
    for y in h / 4..3 * h / 4 {
        for x in w / 8..3 * w / 4 {
            if img.get_pixel(x, y).0 != [255, 255, 255] {
                drawn += 1;
            }
        }
    }
    let area = (h / 2) * (5 * w / 8);
    assert!(
        drawn > area / 100,
        "{}: {drawn} of {area} drawn",
        path.display()
    );
}

/// The SVG names both materials (the legend or the panels' titles) and has a title.
fn check_svg(path: &Path, kind: &str) {
    let svg = std::fs::read_to_string(path).unwrap();
    assert!(svg.starts_with("<svg"), "{kind}");
    for label in ["model = lambert, albedo = 0.5", "model = ward, kd = 0.1"] {
        assert!(
            svg.contains(label),
            "{kind}: no '{label}' in the SVG's text"
        );
    }
    let titles = [
        ("polar", "plane of incidence"),
        ("slice", "BRDF slice"),
        ("albedo", "albedo"),
        ("hemisphere", "hemisphere"),
    ];
    let title = titles.iter().find(|t| t.0 == kind).unwrap().1;
    assert!(svg.contains(title), "{kind}: title");
}

#[test]
fn the_exr_output_of_before_still_works() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("lobe.exr");
    let o = plot("polar", &out, &["--scale", "log"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let img = brdfwave::imageio::read(&out).unwrap();
    assert!(img.width >= 900);
    assert!(img.data.iter().any(|p| p[0] < 0.5));
    assert!(out.with_extension("csv").is_file());
}

#[test]
fn bad_kinds_extensions_and_scales_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let err = |kind: &str, file: &str, extra: &[&str]| {
        let o = plot(kind, &dir.path().join(file), extra);
        assert!(!o.status.success());
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let e = err("pie", "a.png", &[]);
    assert!(
        e.contains("invalid value 'pie'") && e.contains("polar"),
        "{e}"
    );
    let e = err("polar", "a.jpg", &[]);
    assert!(
        e.contains("--out") && e.contains("a.jpg") && e.contains("unknown extension"),
        "{e}"
    );
    let e = err("polar", "a.png", &["--scale", "ln"]);
    assert!(e.contains("unknown scale 'ln'"), "{e}");
    assert!(!dir.path().join("a.jpg").exists() && !dir.path().join("a.csv").exists());
}

/// Renders the Cornell box on the CPU at 24x20, 2 spp, with `seed`, into `path`.
fn render(path: &Path, seed: &str) {
    let o = Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .args(["render", "scenes/cornell-box.toml", "--backend", "cpu"])
        .args([
            "--res", "24x20", "--spp", "2", "--seed", seed, "--quiet", "--out",
        ])
        .arg(path)
        .current_dir(common::repo())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `diff --error-map FILE.png|svg` and `--triptych` draw the FLIP map with its colour bar; the
/// CSV beside holds the FLIP value of every pixel, as `brdfwave::metrics::flip_map` computes it.
#[test]
fn the_error_map_and_triptych_are_figures_with_the_flip_values() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.exr"));
    render(&a, "1");
    render(&b, "2");
    let (map_png, map_svg, tri) = (
        dir.path().join("map.png"),
        dir.path().join("map.svg"),
        dir.path().join("tri.png"),
    );
    let o = Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .arg("diff")
        .args([&a, &b])
        .arg("--error-map")
        .arg(&map_png)
        .arg("--triptych")
        .arg(&tri)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ia, ib) = (
        brdfwave::imageio::read(&a).unwrap(),
        brdfwave::imageio::read(&b).unwrap(),
    );
    let flip = brdfwave::metrics::flip_map(&ia, &ib).unwrap();
    for p in [&map_png, &tri] {
        let (_, rows) = csv(&p.with_extension("csv"));
        assert_eq!(rows.len(), 24 * 20);
        for (r, &f) in rows.iter().zip(&flip) {
            assert_eq!(r[2] as f32, f, "{r:?}");
        }
        check_png(p);
    }
    // The triptych is three panels and the colour bar wide.
    let wide = image::open(&tri).unwrap().width();
    assert!(wide > 2 * image::open(&map_png).unwrap().width(), "{wide}");
    let o = Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .arg("diff")
        .args([&a, &b])
        .arg("--error-map")
        .arg(&map_svg)
        .output()
        .unwrap();
    assert!(o.status.success());
    let svg = std::fs::read_to_string(&map_svg).unwrap();
    assert!(svg.contains("FLIP error") && svg.contains("x (pixels)"));
    let o = Command::new(env!("CARGO_BIN_EXE_brdfwave"))
        .arg("diff")
        .args([&a, &b])
        .arg("--triptych")
        .arg(dir.path().join("tri.exr"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && e.contains("--triptych") && e.contains("unknown extension"),
        "{e}"
    );
}
