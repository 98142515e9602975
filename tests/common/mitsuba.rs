//! Mitsuba 3 as a peer: an XML scene rendered by its Python package, reduced to block means
//! of luminance, and the block-wise two-sample z-test of brdfwave's image against them (the
//! pattern of tests/mitsuba_peer.rs, with the block size and the sample counts as parameters).

use brdfwave::imageio;
use std::path::Path;
use std::process::Command;

/// Rec. 709 luminance weights, on both sides of the comparison.
pub const LUM: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// Mitsuba's block means of luminance (`block` × `block` pixels), one row per render of `spp`
/// samples (seeds 0..renders), and the image's mean luminance over all renders; `None` when
/// Mitsuba 3 cannot be imported.
pub fn block_means(xml: &Path, block: usize, renders: usize, spp: usize) -> Option<Vec<Vec<f64>>> {
    let script = format!(
        r#"
import sys
try:
    import mitsuba as mi, numpy as np
except ImportError:
    print("absent"); sys.exit(0)
mi.set_variant("scalar_rgb")
scene = mi.load_file({xml:?})
for seed in range({renders}):
    a = np.array(mi.render(scene, spp={spp}, seed=seed), dtype=np.float64)[..., :3]
    lum = a @ np.array({lum:?})
    h, w = lum.shape
    b = lum.reshape(h // {block}, {block}, w // {block}, {block}).mean(axis=(1, 3))
    print(" ".join(repr(float(v)) for v in b.ravel()))
"#,
        xml = xml.display().to_string(),
        lum = LUM
    );
    let out = Command::new("python3")
        .args(["-c", &script])
        .output()
        .ok()?;
    assert!(
        out.status.success(),
        "Mitsuba failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    if text.trim() == "absent" {
        return None;
    }
    Some(
        text.lines()
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(' ').map(|v| v.parse().unwrap()).collect())
            .collect(),
    )
}

/// The comparison of brdfwave's image (its variance layer, `spp` samples) scaled by `scale`
/// with Mitsuba's block means: the largest |z| over the blocks, and the ratio of the two
/// images' mean luminances (ours / Mitsuba's).
pub fn compare(
    ours: &imageio::Layered,
    spp: f64,
    scale: f64,
    block: usize,
    peer: &[Vec<f64>],
) -> (f64, f64) {
    let (w, h) = (ours.image.width as usize, ours.image.height as usize);
    let var = ours.variance.as_ref().expect("a variance layer");
    let lum = |c: [f32; 3]| (0..3).map(|i| LUM[i] * c[i] as f64).sum::<f64>();
    let (bw, n) = (w / block, (block * block) as f64);
    let k = peer.len() as f64;
    let (mut worst, mut ours_sum, mut peer_sum) = (0.0f64, 0.0, 0.0);
    for b in 0..bw * (h / block) {
        let (bx, by) = (b % bw * block, b / bw * block);
        let (mut m, mut v) = (0.0, 0.0);
        for y in by..by + block {
            for x in bx..bx + block {
                m += lum(ours.image.get(x as u32, y as u32));
                // The luminance's standard deviation at most Σ w_c σ_c (fully correlated
                // channels): a generous variance, a lenient test.
                let c = var.get(x as u32, y as u32);
                let sd = (0..3)
                    .map(|i| LUM[i] * (c[i].max(0.0) as f64).sqrt())
                    .sum::<f64>();
                v += sd * sd;
            }
        }
        let (m, se2) = (scale * m / n, scale * scale * v / (n * n * spp));
        let pm = peer.iter().map(|r| r[b]).sum::<f64>() / k;
        let pv = peer.iter().map(|r| (r[b] - pm).powi(2)).sum::<f64>() / (k - 1.0) / k;
        worst = worst.max((m - pm).abs() / (se2 + pv).sqrt().max(1e-12));
        ours_sum += m;
        peer_sum += pm;
    }
    (worst, ours_sum / peer_sum)
}

/// brdfwave's render of the XML scene `xml` as the peer tests compare it with Mitsuba's: the
/// CPU reference, the independent sampler (Mitsuba's default, whose variance of one sample the
/// z-test assumes), `spp` samples; written to `exr` and read back with its layers.
pub fn render_ours(xml: &Path, spp: usize, exr: &Path) -> imageio::Layered {
    let spp = spp.to_string();
    super::run_ok(Command::new(env!("CARGO_BIN_EXE_brdfwave")).args([
        "render",
        xml.to_str().unwrap(),
        "--backend",
        "cpu",
        "--quiet",
        "--sampler",
        "independent",
        "--spp",
        &spp,
        "--out",
        exr.to_str().unwrap(),
    ]));
    imageio::read_layered(exr).unwrap()
}
