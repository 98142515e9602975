//! Renders split by sample range and by tile, written as partial films and merged
//! (`brdfwave render --samples/--tile`, `brdfwave merge`, `src/film/`): merged CPU parts equal
//! one CPU render bit for bit, GPU parts and parts from both backends agree within rounding, and
//! merge refuses parts that do not make one render.

mod common;

use brdfwave::bvh;
use brdfwave::film::{self, Part, Tile};
use brdfwave::imageio::Image;
use brdfwave::render::{self, Backend, RenderRequest};
use brdfwave::scene::Scene;
use common::{context, finish, scene};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::Command;

fn tile(x: u32, y: u32, width: u32, height: u32) -> Tile {
    Tile {
        x,
        y,
        width,
        height,
    }
}

/// Renders one part on `backend` through the renderer interface and writes it to `dir/name`.
fn part_on(
    backend: Backend<'_>,
    s: &Scene,
    samples: Range<u32>,
    t: Tile,
    dir: &Path,
    name: &str,
) -> PathBuf {
    let b = bvh::build(s);
    let mut r = render::open(backend, s, b.into(), t).unwrap();
    let request = RenderRequest {
        samples,
        take_film: true,
    };
    let rendered = r.render(&request, &|_| {}).unwrap();
    let film = rendered.film.expect("the film asked for");
    let on = r.describe().backend;
    let path = dir.join(name);
    film::write_part(
        &path,
        &Part::of_render("test.toml", s, film, &rendered.output, on, "test", 0.0),
    )
    .unwrap();
    path
}

/// Renders one part on the CPU and writes it to `dir/name`.
fn cpu_part(s: &Scene, samples: Range<u32>, t: Tile, dir: &Path, name: &str) -> PathBuf {
    part_on(Backend::Cpu, s, samples, t, dir, name)
}

fn crop(img: &Image, t: Tile) -> Image {
    Image::from_fn(t.width, t.height, |x, y| img.get(t.x + x, t.y + y))
}

/// Largest difference relative to the pixel's value (plus a floor for near-black pixels).
fn max_rel_diff(a: &Image, b: &Image) -> f32 {
    a.data
        .iter()
        .zip(&b.data)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / (q[c].abs() + 1e-3)))
        .fold(0.0, f32::max)
}

/// CPU parts, in any split of the samples and tiles that differ from one sample range to the
/// next, merge into the single render's mean and variance bit for bit; on a one-model scene and
/// on the lineup (one sphere per model).
#[test]
fn cpu_parts_merge_into_the_single_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    for (name, w, h) in [("cornell-box.toml", 24, 18), ("lineup.toml", 32, 12)] {
        let s = scene(name, w, h, 11, 5, 3);
        let whole = common::render_cpu(&s);
        let full = Tile::full(w, h);
        let (left, right) = (tile(0, 0, 10, h), tile(10, 0, w - 10, h));
        let (top, bottom) = (tile(0, 0, w, 7), tile(0, 7, w, h - 7));
        let parts = vec![
            cpu_part(&s, 0..3, full, dir.path(), "a.bwfilm"),
            cpu_part(&s, 3..4, left, dir.path(), "b.bwfilm"),
            cpu_part(&s, 3..4, right, dir.path(), "c.bwfilm"),
            cpu_part(&s, 4..9, top, dir.path(), "d.bwfilm"),
            cpu_part(&s, 4..9, bottom, dir.path(), "e.bwfilm"),
            cpu_part(&s, 9..11, full, dir.path(), "f.bwfilm"),
        ];
        // Any order of the files.
        let mut shuffled = parts.clone();
        shuffled.reverse();
        shuffled.swap(1, 4);
        let m = film::merge(&shuffled).unwrap();
        assert_eq!(m.samples, 0..11);
        assert!(
            m.mean.data == whole.mean.data,
            "{name}: merged mean differs from the single render"
        );
        assert!(
            m.variance.data == whole.variance.data,
            "{name}: merged variance differs from the single render"
        );
        assert_eq!(m.extension_rays, whole.extension_rays, "{name}");
        assert_eq!(m.shadow_rays, whole.shadow_rays, "{name}");
    }
}

/// On the GPU, a tile renders each of its pixels exactly as the whole image does, and parts
/// (by samples and by tile) merge into the single render within f32 rounding of the sums; parts
/// from both backends merge too, within the agreement of the two backends.
#[test]
fn gpu_and_mixed_parts_merge_within_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let ctx = context();
    let s = scene("cornell-box.toml", 24, 18, 9, 5, 3);
    let compiler = brdfwave::vk::ShaderCompiler::new().unwrap();
    let b = bvh::build(&s);
    let b = std::sync::Arc::new(b);
    let whole = render::render_all(Backend::gpu(&ctx, &compiler), &s, b.clone()).unwrap();
    let full = Tile::full(24, 18);
    let t = tile(5, 3, 7, 11);
    // One part on the GPU, written to the folder (the compiler above, its shaders cached).
    let gpu_part = |samples: Range<u32>, t: Tile, name: &str| {
        part_on(
            Backend::gpu(&ctx, &compiler),
            &s,
            samples,
            t,
            dir.path(),
            name,
        )
    };
    let a = gpu_part(0..9, t, "tile.bwfilm");
    let m = film::read_part(&a).unwrap().film.images().0;
    assert!(
        m.data == crop(&whole.mean, t).data,
        "a GPU tile differs from the same pixels of the whole image"
    );

    let parts = [
        gpu_part(0..4, full, "g0.bwfilm"),
        gpu_part(4..9, tile(0, 0, 24, 10), "g1.bwfilm"),
        gpu_part(4..9, tile(0, 10, 24, 8), "g2.bwfilm"),
    ];
    let m = film::merge(&parts).unwrap();
    let d = max_rel_diff(&m.mean, &whole.mean);
    assert!(
        d < 1e-5,
        "GPU parts merged differ by {d} from the single render"
    );

    let mixed = [
        parts[0].clone(),
        cpu_part(&s, 4..9, full, dir.path(), "c1.bwfilm"),
    ];
    let m = film::merge(&mixed).unwrap();
    let d = max_rel_diff(&m.mean, &whole.mean);
    assert!(
        d < 1e-4,
        "GPU and CPU parts merged differ by {d} from the GPU render"
    );
    finish(ctx);
}

/// Merge refuses sets that are not one render, naming the files and what is wrong.
#[test]
fn merge_refuses_parts_that_do_not_make_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = scene("cornell-box.toml", 12, 8, 4, 3, 1);
    let full = Tile::full(12, 8);
    let a = cpu_part(&s, 0..2, full, d, "a.bwfilm");
    let b = cpu_part(&s, 2..4, full, d, "b.bwfilm");
    let gap = cpu_part(&s, 3..4, full, d, "gap.bwfilm");
    let over = cpu_part(&s, 1..4, full, d, "over.bwfilm");
    let half = cpu_part(&s, 2..4, tile(0, 0, 12, 4), d, "half.bwfilm");
    let mut other = s.clone();
    other.integrator.seed = 2;
    let other = cpu_part(&other, 2..4, full, d, "other-seed.bwfilm");
    let err = |parts: &[&PathBuf]| -> String {
        let v: Vec<PathBuf> = parts.iter().map(|p| p.to_path_buf()).collect();
        format!("{:#}", film::merge(&v).err().expect("merge refuses"))
    };
    assert!(film::merge(&[a.clone(), b.clone()]).is_ok());
    let e = err(&[&a, &gap]);
    assert!(
        e.contains("samples 2..3") && e.contains("in no part"),
        "{e}"
    );
    let e = err(&[&a, &over]);
    assert!(e.contains("samples 1..2") && e.contains("two parts"), "{e}");
    assert!(e.contains("a.bwfilm") && e.contains("over.bwfilm"), "{e}");
    let e = err(&[&a, &half]);
    assert!(e.contains("same samples"), "{e}");
    let e = err(&[&half]);
    assert!(
        e.contains("pixel (0, 4)") && e.contains("no part's tile"),
        "{e}"
    );
    let e = err(&[&a, &other]);
    assert!(e.contains("different scenes or settings"), "{e}");
    assert!(e.contains("other-seed.bwfilm"), "{e}");
    let mut big = s.clone();
    big.width = 13;
    let big = cpu_part(&big, 2..4, Tile::full(13, 8), d, "big.bwfilm");
    assert!(err(&[&a, &big]).contains("different scenes or settings"));
    // A damaged or foreign file is named.
    let bytes = std::fs::read(&b).unwrap();
    let cut = d.join("cut.bwfilm");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    let e = err(&[&a, &cut]);
    assert!(e.contains("cut.bwfilm") && e.contains("data holds"), "{e}");
    assert!(err(&[&a, &d.join("missing.bwfilm")]).contains("missing.bwfilm"));
}

/// The local way to split a render (docs/splitting.md): scripts/render-parts.sh renders parts in two
/// processes with xargs -P and merges them; the result is the single CPU render, bit for bit.
/// Run again, it keeps the parts it has; with a part deleted, merge refuses until it is back.
#[test]
fn render_parts_script_in_two_processes_equals_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let exe = env!("CARGO_BIN_EXE_brdfwave");
    let scene = common::repo().join("scenes/cornell-box.toml");
    let opts = ["--backend", "cpu", "--res", "20x16", "--max-depth", "4"];
    let run = |args: &[&str]| {
        let o = Command::new("bash")
            .arg(common::repo().join("scripts/render-parts.sh"))
            .args(args)
            .args(opts)
            .env("BRDFWAVE", exe)
            .current_dir(d)
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let scene_arg = scene.to_str().unwrap();
    let (ok, stderr) = run(&[scene_arg, "10", "3", "2", "merged.exr"]);
    assert!(ok, "{stderr}");
    let single = Command::new(exe)
        .arg("render")
        .arg(&scene)
        .args(["--spp", "10", "--out", "single.exr"])
        .args(opts)
        .current_dir(d)
        .output()
        .unwrap();
    assert!(single.status.success());
    let read = |n: &str| brdfwave::imageio::read(&d.join(n)).unwrap();
    assert!(read("merged.exr").data == read("single.exr").data);
    let parts = d.join("merged.parts");
    assert_eq!(std::fs::read_dir(&parts).unwrap().count(), 3);

    // A lost part is rendered again; merge alone refuses the incomplete set.
    std::fs::remove_file(parts.join("part-1-of-3.bwfilm")).unwrap();
    let merge = Command::new(exe)
        .arg("merge")
        .arg(parts.join("part-0-of-3.bwfilm"))
        .arg(parts.join("part-2-of-3.bwfilm"))
        .args(["--out", "incomplete.exr"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(!merge.status.success());
    let e = String::from_utf8_lossy(&merge.stderr);
    assert!(
        e.contains("samples 3..6") && e.contains("in no part"),
        "{e}"
    );
    assert!(!d.join("incomplete.exr").exists());
    std::fs::remove_file(d.join("merged.exr")).unwrap();
    let (ok, stderr) = run(&[scene_arg, "10", "3", "2", "merged.exr"]);
    assert!(ok, "{stderr}");
    assert!(read("merged.exr").data == read("single.exr").data);
}

/// The Slurm example (docs/distributed/slurm.sbatch) run as Slurm would run it: once per array
/// task with SLURM_ARRAY_TASK_ID (and SLURM_CPUS_PER_TASK, the render's threads) set, then once
/// without for the merge job. Its image is the
/// single CPU render, bit for bit; with a task's part missing, the merge job fails.
#[test]
fn slurm_example_renders_and_merges_like_one_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let exe = env!("CARGO_BIN_EXE_brdfwave");
    let out = d.join("slurm.exr");
    let job = |task: Option<u32>| {
        let mut c = Command::new("bash");
        c.arg("docs/distributed/slurm.sbatch")
            .current_dir(common::repo())
            .env("BRDFWAVE", exe)
            .env("SCENE", "scenes/cornell-box.toml")
            .env("SPP", "7")
            .env("PARTS", "3")
            .env("RES", "20x16")
            .env("BACKEND", "cpu")
            .env("OUT", &out)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("SLURM_CPUS_ON_NODE");
        if let Some(t) = task {
            // The allocation's CPUs are the render's threads.
            c.env("SLURM_ARRAY_TASK_ID", t.to_string())
                .env("SLURM_CPUS_PER_TASK", "3");
        }
        let o = c.output().unwrap();
        // The render's summary goes to stdout, its errors to stderr.
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    for t in [2, 0] {
        let (ok, e) = job(Some(t));
        assert!(ok && e.contains("(3 threads)"), "{e}");
    }
    let (ok, e) = job(None);
    assert!(!ok && e.contains("part-1-of-3.bwfilm"), "{e}");
    let (ok, e) = job(Some(1));
    assert!(ok, "{e}");
    let (ok, e) = job(None);
    assert!(ok, "{e}");
    let single = d.join("single.exr");
    let o = Command::new(exe)
        .arg("render")
        .arg(common::repo().join("scenes/cornell-box.toml"))
        .args(["--backend", "cpu", "--res", "20x16", "--spp", "7", "--out"])
        .arg(&single)
        .output()
        .unwrap();
    assert!(o.status.success());
    let read = |p: &Path| brdfwave::imageio::read(p).unwrap();
    assert!(read(&out).data == read(&single).data);
}

/// An image whose film does not fit one storage buffer of the device (lavapipe: 128 MiB, about
/// 8 M pixels) is refused with a message that points to --tile, and a tile of it renders.
#[test]
fn an_image_too_large_for_the_device_renders_by_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let exe = env!("CARGO_BIN_EXE_brdfwave");
    let scene = common::repo().join("scenes/cornell-box.toml");
    let run = |extra: &[&str]| {
        Command::new(exe)
            .arg("render")
            .arg(&scene)
            .args(["--res", "4096x4096", "--spp", "1", "--max-depth", "2"])
            .args(extra)
            .current_dir(dir.path())
            .output()
            .unwrap()
    };
    // The film of the whole image: 4096² pixels × 16 bytes = 256 MiB.
    let range = {
        let ctx = context();
        let r = ctx.limits.max_storage_buffer_range as u64;
        finish(ctx);
        r
    };
    let o = run(&["--out", "whole.exr"]);
    let e = String::from_utf8_lossy(&o.stderr);
    if range < 256 << 20 {
        assert!(!o.status.success(), "a 256 MiB film was accepted");
        assert!(
            e.contains("an image of 4096x4096") && e.contains("--tile"),
            "{e}"
        );
    } else {
        assert!(o.status.success(), "{e}");
    }
    let o = run(&["--tile", "2000,3000,48,32", "--out", "tile.bwfilm"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let part = film::read_part(&dir.path().join("tile.bwfilm")).unwrap();
    assert_eq!((part.header.width, part.header.height), (4096, 4096));
    assert_eq!(part.film.tile, tile(2000, 3000, 48, 32));
}
