//! Hostile input to the command line, one test per crash class: files whose headers declare
//! huge sizes (every image format and `.bwfilm`), a corrupt cache entry, full stdout and stderr
//! (`/dev/full`), bad options of `stress`. Each must end with a clear error (exit status 1,
//! naming the file and what is wrong) or succeed, never abort, panic or write half a file.

mod common;

use common::cli::{s, Cli};

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const CLI: Cli = Cli {
    tag: "adv",
    own_cache: false,
    env_remove: &[],
};

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_brdfwave"));
    c.current_dir(common::repo());
    c
}

fn check(out: Output, what: &str) -> Output {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !stderr.contains("panicked") && !stderr.contains("memory allocation"),
        "{what}: crashed:\n{stderr}"
    );
    assert!(
        out.status.code().is_some(),
        "{what}: killed by a signal ({}):\n{stderr}",
        out.status
    );
    out
}

/// Runs `args`, which must fail with status 1 and a message containing every needle.
#[track_caller]
fn fails_with(args: &[&str], needles: &[&str]) -> String {
    let out = check(bin().args(args).output().unwrap(), &format!("{args:?}"));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{args:?}:\n{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: no {n:?} in:\n{err}");
    }
    err
}

fn small_exr(path: &Path) {
    brdfwave::imageio::write(path, &brdfwave::imageio::Image::filled(8, 8, [0.5; 3])).unwrap();
}

/// An EXR of 8x8 pixels whose header declares a data window of 1,000,000 x 10,000, with the
/// chunk count and offset table (625 chunks of 16 rows) that such a window needs, so that the
/// reader gets as far as allocating the image.
fn exr_bomb(path: &Path) {
    small_exr(path);
    let b = std::fs::read(path).unwrap();
    let find = |key: &[u8]| {
        b.windows(key.len())
            .position(|w| w == key)
            .unwrap_or_else(|| panic!("no {key:?} in the EXR header"))
            + key.len()
    };
    let mut head = b[..find(b"scanlineimage") + 1].to_vec();
    let window = find(b"dataWindow\0box2i\0") + 4;
    head[window + 8..window + 12].copy_from_slice(&999_999i32.to_le_bytes());
    head[window + 12..window + 16].copy_from_slice(&9_999i32.to_le_bytes());
    let count = find(b"chunkCount\0int\0") + 4;
    head[count..count + 4].copy_from_slice(&625i32.to_le_bytes());
    let chunk = &b[head.len() + 8..];
    let first = (head.len() + 625 * 8) as u64;
    for _ in 0..625 {
        head.extend_from_slice(&first.to_le_bytes());
    }
    head.extend_from_slice(chunk);
    std::fs::write(path, head).unwrap();
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

/// A PNG whose header declares 20,000 x 20,000 grey pixels (400 MB of data, 4.8 GB as f32).
fn png_bomb(path: &Path) {
    let mut b = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&20_000u32.to_be_bytes());
    ihdr.extend_from_slice(&20_000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    png_chunk(&mut b, b"IHDR", &ihdr);
    png_chunk(
        &mut b,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    png_chunk(&mut b, b"IEND", &[]);
    std::fs::write(path, b).unwrap();
}

/// Every image reader refuses a size over the film limit from the header, before allocating
/// it: `diff` ended in `memory allocation of 120000000000 bytes failed` (SIGABRT) on the EXR.
#[test]
fn image_header_bombs_are_refused_by_every_reader() {
    let good = CLI.tmp("good.exr");
    small_exr(&good);
    let (exr, png, pfm) = (
        CLI.tmp("bomb.exr"),
        CLI.tmp("bomb.png"),
        CLI.tmp("bomb.pfm"),
    );
    exr_bomb(&exr);
    png_bomb(&png);
    let mut b = b"PF\n100000 100000\n-1.0\n".to_vec();
    b.extend_from_slice(&[0; 12]);
    std::fs::write(&pfm, b).unwrap();
    for (bomb, size) in [
        (&exr, "1000000x10000"),
        (&png, "20000x20000"),
        (&pfm, "100000x100000"),
    ] {
        fails_with(
            &["diff", s(bomb), s(&good)],
            &[s(bomb), size, "over the limit of 16384"],
        );
        fails_with(&["diff", s(&good), s(bomb)], &[s(bomb), size]);
    }
}

/// A reference of the benchmark: given as --reference, a clean error; found in the cache, it
/// is discarded and rendered again (it made every later `bench` of the scene abort).
#[test]
fn a_corrupt_bench_reference_is_refused_or_rebuilt() {
    let cache = CLI.tmp("bench-cache");
    let out = CLI.tmp("bench-out");
    let bench = |extra: &[&str]| {
        let mut args = vec![
            "bench",
            "scenes/cornell-box.toml",
            "--res",
            "8x8",
            "--budget",
            "1",
            "--reference-spp",
            "4",
            "--configs",
            "cpu",
            "--out",
            s(&out),
        ];
        args.extend_from_slice(extra);
        let o = bin()
            .args(&args)
            .env("BRDFWAVE_CACHE_DIR", &cache)
            .output()
            .unwrap();
        check(o, "bench")
    };
    let o = bench(&[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The reference image (and, beside it, its own expected error as text).
    let cached: Vec<PathBuf> = std::fs::read_dir(cache.join("reference"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    assert_eq!(cached.len(), 1);
    exr_bomb(&cached[0]);
    let o = bench(&[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("discarding the cached reference"), "{err}");
    // Rebuilt: an 8x8 image again.
    let img = brdfwave::imageio::read(&cached[0]).expect("the cache entry was rebuilt");
    assert_eq!((img.width, img.height), (8, 8));
    let bomb = CLI.tmp("bench-bomb.exr");
    exr_bomb(&bomb);
    let o = bench(&["--reference", s(&bomb)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(s(&bomb)) && err.contains("over the limit"),
        "{err}"
    );
}

/// Renders samples `samples` of a 2-spp render of the Cornell box at 8x8 on the CPU into a
/// partial film.
fn part(name: &str, samples: &str) -> PathBuf {
    let p = CLI.tmp(name);
    let o = bin()
        .args([
            "render",
            "scenes/cornell-box.toml",
            "--backend",
            "cpu",
            "--res",
            "8x8",
            "--spp",
            "2",
        ])
        .args(["--samples", samples, "--out", s(&p)])
        .output()
        .unwrap();
    assert!(
        check(o, "render").status.success(),
        "render of a partial film"
    );
    p
}

/// Rewrites the JSON header of the partial film `from` with `edit` into `to`.
fn patch_header(from: &Path, to: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let bytes = std::fs::read(from).unwrap();
    let n = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut header: serde_json::Value = serde_json::from_slice(&bytes[16..16 + n]).unwrap();
    edit(&mut header);
    let json = serde_json::to_vec(&header).unwrap();
    let mut out = bytes[..12].to_vec();
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&json);
    while out.len() % 8 != 0 {
        out.push(0);
    }
    out.extend_from_slice(&bytes[(16 + n).div_ceil(8) * 8..]);
    std::fs::write(to, out).unwrap();
}

/// A partial film whose header declares a 1,000,000 x 100,000 image around a small tile: the
/// data length matches the tile, and `merge` allocated the whole image (an abort).
#[test]
fn a_bwfilm_header_bomb_is_refused() {
    let good = part("part.bwfilm", "0..2");
    let bomb = CLI.tmp("bomb.bwfilm");
    patch_header(&good, &bomb, |h| {
        h["width"] = 1_000_000.into();
        h["height"] = 100_000.into();
    });
    fails_with(
        &["merge", s(&bomb), "--out", s(&CLI.tmp("merged.exr"))],
        &[s(&bomb), "1000000x100000", "16384"],
    );
}

/// Counters of parts that add up to more than 2^64 are refused (they wrapped), and a flipped
/// bit in a film's body is caught by its block's checksum (it changed a pixel silently).
#[test]
fn merge_refuses_overflowing_counts_and_damaged_bodies() {
    let (a, b) = (part("a.bwfilm", "0..1"), part("b.bwfilm", "1..2"));
    let merged = CLI.tmp("ab.exr");
    let o = check(
        bin()
            .args(["merge", s(&a), s(&b), "--out", s(&merged)])
            .output()
            .unwrap(),
        "merge",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (a2, b2) = (CLI.tmp("a-max.bwfilm"), CLI.tmp("b-max.bwfilm"));
    for (from, to) in [(&a, &a2), (&b, &b2)] {
        patch_header(from, to, |h| h["extension_rays"] = u64::MAX.into());
    }
    fails_with(
        &["merge", s(&a2), s(&b2), "--out", s(&merged)],
        &["extension-ray counts", "2^64"],
    );
    let mut bytes = std::fs::read(&a).unwrap();
    let at = bytes.len() - 8 * 6 * 10 + 3;
    bytes[at] ^= 0x10;
    let damaged = CLI.tmp("a-damaged.bwfilm");
    std::fs::write(&damaged, bytes).unwrap();
    fails_with(
        &["merge", s(&damaged), s(&b), "--out", s(&merged)],
        &[s(&damaged), "checksum"],
    );
}

fn dev_full() -> Stdio {
    Stdio::from(
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap(),
    )
}

/// A full stdout is an error exit that says so (it was a panic, exit 101, and `brdf eval` lost
/// its CSV); a full stderr loses the warnings, never the work (a warning panicked before the
/// render and no image was written).
#[test]
fn full_stdout_and_stderr_never_panic() {
    let img = CLI.tmp("full.exr");
    let quick = ["render", "scenes/cornell-box.toml"];
    let run = |args: &[&str], stdout: Stdio, stderr: Stdio| {
        let o = bin()
            .args(args)
            .stdout(stdout)
            .stderr(stderr)
            .output()
            .unwrap();
        check(o, &format!("{args:?}"))
    };
    let good = CLI.tmp("full-good.exr");
    small_exr(&good);
    let dirs = CLI.tmp("full-dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    let mut render: Vec<&str> = quick.to_vec();
    render.extend(common::QUICK_RENDER);
    render.extend(["--out", s(&img)]);
    for args in [
        render.clone(),
        vec!["diff", s(&good), s(&good)],
        vec![
            "brdf",
            "eval",
            "--material",
            "model = \"lambert\"",
            "--dirs",
            s(&dirs),
            "--backend",
            "cpu",
        ],
        vec!["devices"],
    ] {
        let o = run(&args, dev_full(), Stdio::piped());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("cannot write to standard output"), "{err}");
    }
    // A warning (--wave-paths with the CPU backend) to a full stderr: the render goes on.
    let _ = std::fs::remove_file(&img);
    let mut warned = render.clone();
    warned.extend(["--wave-paths", "64"]);
    let o = run(&warned, Stdio::piped(), dev_full());
    assert!(o.status.success(), "{}", o.status);
    assert!(img.exists(), "the image was written");
}

/// `stress` checks its output and its device before running any case: an unwritable failure
/// file and a device that does not exist are refused up front, and no failure file is written.
#[test]
fn stress_refuses_a_bad_failure_file_or_device_up_front() {
    let failures = CLI.tmp("stress-failures.jsonl");
    let _ = std::fs::remove_file(&failures);
    let t = std::time::Instant::now();
    fails_with(
        &[
            "stress",
            "--budget",
            "30",
            "--device",
            "no-such-device-xyz",
            "--failures",
            s(&failures),
        ],
        &["--device", "no-such-device-xyz"],
    );
    assert!(!failures.exists());
    fails_with(
        &[
            "stress",
            "--budget",
            "30",
            "--failures",
            "/proc/brdfwave/failures.jsonl",
        ],
        &["--failures", "/proc/brdfwave/failures.jsonl"],
    );
    assert!(
        t.elapsed().as_secs() < 20,
        "refused before the 30-second budget was spent"
    );
}

/// An output that is one of the command's inputs is refused before anything is written, as
/// `merge` and `diff` already did: `brdf eval --dirs x.csv --out x.csv` replaced its input, and
/// a TOML scene named `.exr` given as its own `--out` was overwritten by the image.
#[test]
fn an_output_that_is_an_input_is_refused() {
    let dirs = CLI.tmp("same-dirs.csv");
    let text = "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n";
    std::fs::write(&dirs, text).unwrap();
    fails_with(
        &[
            "brdf",
            "eval",
            "--material",
            "model = \"lambert\"",
            "--backend",
            "cpu",
            "--dirs",
            s(&dirs),
            "--out",
            s(&dirs),
        ],
        &["--out", "--dirs file", "replace the input"],
    );
    assert_eq!(std::fs::read_to_string(&dirs).unwrap(), text);
    let scene = CLI.tmp("scene-named.exr");
    let toml = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    std::fs::write(&scene, &toml).unwrap();
    let mut args = vec!["render", s(&scene)];
    args.extend(common::QUICK_RENDER);
    args.extend(["--out", s(&scene)]);
    fails_with(&args, &["--out", "scene file", "replace the input"]);
    assert_eq!(std::fs::read_to_string(&scene).unwrap(), toml);
}

/// Non-finite pixels fail a comparison (two all-NaN images scored RMSE 0 and FLIP 0), and a
/// non-finite benchmark reference is refused (it gave relMSE 0).
#[test]
fn non_finite_images_do_not_compare() {
    let nan = CLI.tmp("allnan.exr");
    brdfwave::imageio::write(&nan, &brdfwave::imageio::Image::filled(4, 4, [f32::NAN; 3])).unwrap();
    let good = CLI.tmp("finite.exr");
    brdfwave::imageio::write(&good, &brdfwave::imageio::Image::filled(4, 4, [0.5; 3])).unwrap();
    for (a, b) in [(&nan, &nan), (&good, &nan), (&nan, &good)] {
        fails_with(&["diff", s(a), s(b)], &["non-finite", "do not compare"]);
    }
    let o = check(
        bin().args(["diff", s(&good), s(&good)]).output().unwrap(),
        "diff",
    );
    assert!(o.status.success());
    fails_with(
        &[
            "bench",
            "scenes/cornell-box.toml",
            "--res",
            "4x4",
            "--configs",
            "cpu",
            "--reference",
            s(&nan),
        ],
        &["--reference", "non-finite"],
    );
}

/// A CPU render whose film cannot fit is refused up front with the figure and the tile advice
/// (under a 4 GB address-space limit, 16384x16384 aborted: `memory allocation of … failed`).
#[test]
fn a_cpu_render_too_large_for_memory_is_refused_up_front() {
    let bin = env!("CARGO_BIN_EXE_brdfwave");
    for out in ["big.png", "big.bwfilm"] {
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -v 4000000 && exec '{bin}' render scenes/cornell-box.toml --backend cpu \
                 --res 16384x16384 --spp 1 --out '{}'",
                s(&CLI.tmp(out))
            ))
            .current_dir(common::repo())
            .output()
            .unwrap();
        let o = check(o, "render 16384x16384");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        common::assert_mentions(&err, &["16384x16384", "MiB", "--tile"]);
        assert!(!CLI.tmp(out).exists());
    }
}

/// An output name longer than a file name may be is refused before the render (the up-front
/// probe used a shortened name, so it passed, and the write failed after the render).
#[test]
fn an_over_long_output_name_is_refused_up_front() {
    let long = CLI.tmp(&format!("{}.png", "n".repeat(300)));
    let mut args = vec!["render", "scenes/cornell-box.toml"];
    args.extend(common::QUICK_RENDER);
    args.extend(["--out", s(&long)]);
    fails_with(&args, &["--out", "304 bytes long", "255"]);
}

/// A signal during a write keeps the old output and leaves no temporary file (`.NAME.*.tmp`
/// stayed behind). The process is stopped the moment a temporary file of its output appears
/// (the write's, or the writability probe's at start-up), sent SIGTERM and continued, so the
/// signal lands while the temporary exists. On a loaded machine the process may finish
/// between the sighting and the stop (it is then a zombie, which `kill` still "stops"): such
/// an attempt proves nothing and is run again.
#[test]
#[cfg(unix)]
fn a_signal_during_a_write_leaves_the_old_output_and_no_temporary() {
    let dir = CLI.tmp("signal");
    let out = dir.join("big.pfm");
    let temporaries = || {
        std::fs::read_dir(&dir)
            .unwrap()
            .filter(|e| {
                let n = e
                    .as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .into_owned();
                n.starts_with(".big.pfm.") && n.ends_with(".tmp")
            })
            .count()
    };
    for _attempt in 0..10 {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(&out, b"old").unwrap();
        let mut child = bin()
            .args(["render", "scenes/cornell-box.toml", "--backend", "cpu"])
            .args(["--res", "1024x1024", "--spp", "1", "--max-depth", "1"])
            .args(["--out", s(&out)])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let pid = child.id().to_string();
        let kill = |sig: &str| {
            Command::new("kill")
                .args([sig, &pid])
                .status()
                .unwrap()
                .success()
        };
        // The state letter of /proc/PID/stat: 'T' stopped, 'Z' finished and not yet reaped.
        let state = || {
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            stat.rsplit(')')
                .next()
                .and_then(|r| r.trim_start().chars().next())
        };
        let t = std::time::Instant::now();
        let mut caught = false;
        while t.elapsed().as_secs() < 60 {
            if temporaries() > 0 {
                caught = kill("-STOP");
                break;
            }
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
        let stopped = caught && {
            // The stop is delivered asynchronously: wait for it to show.
            let t = std::time::Instant::now();
            while state() == Some('R') || state() == Some('S') || state() == Some('D') {
                if t.elapsed().as_secs() > 10 {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            state() == Some('T')
        };
        if !stopped {
            // Finished before the stop (or never wrote): nothing was tested; try again.
            let _ = child.wait();
            continue;
        }
        assert!(kill("-TERM") && kill("-CONT"));
        let status = child.wait().unwrap();
        assert!(!status.success(), "the signal ended the render");
        assert_eq!(
            std::fs::read(&out).unwrap(),
            b"old",
            "the old output is kept"
        );
        assert_eq!(temporaries(), 0, "no temporary file left");
        return;
    }
    panic!("in 10 attempts the render was never stopped while a temporary file existed");
}

/// `brdf eval` of a Lambert material on the CPU over the directions in `dirs`.
/// Writes `csv` to the scratch file `name` and runs `brdf eval` of a Lambert material on its
/// directions; returns the run and the file.
fn eval_lambert(name: &str, csv: &str) -> (Output, PathBuf) {
    let dirs = CLI.tmp(name);
    std::fs::write(&dirs, csv).unwrap();
    let o = check(
        bin()
            .args(["brdf", "eval", "--material", "model = \"lambert\""])
            .args(["--backend", "cpu", "--dirs", s(&dirs)])
            .output()
            .unwrap(),
        "brdf eval",
    );
    (o, dirs)
}

/// Messages of issue 22 item 15: a part header's text with escape codes is refused, not
/// printed raw; a byte-order mark before a CSV header is accepted; He's tau gives its true
/// range.
#[test]
fn messages_say_what_is_wrong() {
    let good = part("msg.bwfilm", "0..2");
    let escaped = CLI.tmp("escaped.bwfilm");
    patch_header(&good, &escaped, |h| h["scene"] = "x\n\u{1b}[31mred".into());
    fails_with(
        &["merge", s(&escaped), "--out", s(&CLI.tmp("esc.exr"))],
        &["header field 'scene'", "control characters"],
    );
    let (o, dirs) = eval_lambert(
        "bom.csv",
        "\u{feff}wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n",
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    fails_with(
        &[
            "brdf",
            "eval",
            "--material",
            "model = \"he\"\ntau = -1",
            "--backend",
            "cpu",
            "--dirs",
            s(&dirs),
        ],
        &["tau", "> 0 and at most 1000"],
    );
}

/// A negative number for a count is an invalid value of its option (clap's tip to write
/// `-- -1` did not work).
#[test]
fn a_negative_count_is_an_invalid_value() {
    for args in [
        ["render", "scenes/cornell-box.toml", "--spp", "-1"],
        ["render", "scenes/cornell-box.toml", "--max-depth", "-3"],
    ] {
        let o = check(bin().args(args).output().unwrap(), "render");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains(&format!("invalid value '{}' for '{}", args[3], args[2])),
            "{err}"
        );
        assert!(!err.contains("-- -"), "{err}");
    }
}

/// Directions below the horizon give 0 with a warning that counts them (they gave 0 silently).
#[test]
fn brdf_eval_warns_below_the_horizon() {
    let (o, _) = eval_lambert(
        "below.csv",
        "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n0,0,-1,0,0,1\n0,0,1,0.6,0,-0.8\n",
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    common::assert_mentions(&err, &["2 of 3 direction pairs", "below the horizon"]);
}

/// With no file descriptor left, Vulkan's failure is named as that, not as a missing Vulkan
/// installation. The test runs itself again as a child process, which uses up its descriptors
/// (under a lowered limit) and then asks for the device list.
#[test]
fn no_file_descriptor_left_is_named_as_such() {
    const CHILD: &str = "BRDFWAVE_TEST_FD_CHILD";
    if std::env::var_os(CHILD).is_some() {
        let limit = libc::rlimit {
            rlim_cur: 64,
            rlim_max: 64,
        };
        // SAFETY: plain system calls on this process's own limit.
        assert_eq!(unsafe { libc::setrlimit(libc::RLIMIT_NOFILE, &limit) }, 0);
        let mut held = Vec::new();
        while let Ok(f) = std::fs::File::open("/dev/null") {
            held.push(f);
            assert!(held.len() < 64, "the limit did not apply");
        }
        let e = brdfwave::vk::Context::list_devices().unwrap_err();
        drop(held);
        println!("CHILD-ERROR: {}", brdfwave::errors::chain(&e));
        return;
    }
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "no_file_descriptor_left_is_named_as_such",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, "1")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "child failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = text
        .lines()
        .find_map(|l| l.find("CHILD-ERROR: ").map(|i| &l[i..]))
        .unwrap_or_else(|| panic!("no error line from the child:\n{text}"));
    assert!(
        line.contains("no file descriptor left") && !line.contains("apt-get install"),
        "{line}"
    );
}

/// A text input that is not UTF-8 (a scene, an OBJ mesh, a direction CSV) is refused with the
/// line and column where it stops being UTF-8.
#[test]
fn non_utf8_text_inputs_are_located() {
    let scene = CLI.tmp("latin1.toml");
    std::fs::write(&scene, b"# caf\xe9\n[camera]\n").unwrap();
    fails_with(
        &["render", s(&scene)],
        &["latin1.toml", "line 1, column 6", "0xe9", "not UTF-8"],
    );
    let csv = CLI.tmp("dirs.csv");
    std::fs::write(&csv, b"wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,\xff1\n").unwrap();
    fails_with(
        &[
            "brdf",
            "eval",
            "--material",
            "model = \"lambert\"",
            "--dirs",
            s(&csv),
        ],
        &["dirs.csv", "line 2, column 11", "0xff"],
    );
    let obj = CLI.tmp("mesh.obj");
    std::fs::write(&obj, b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# \xc3(\nf 1 2 3\n").unwrap();
    let with_obj = CLI.tmp("with-obj.toml");
    let cornell = std::fs::read_to_string(common::repo().join("scenes/cornell-box.toml")).unwrap();
    std::fs::write(
        &with_obj,
        format!("{cornell}\n[[shapes]]\nobj = \"mesh.obj\"\nmaterial = \"white\"\n"),
    )
    .unwrap();
    fails_with(
        &["render", s(&with_obj)],
        &["mesh.obj", "line 4, column 3", "0xc3"],
    );
}

/// What every reader of a file a user names is given instead of a regular file: `/dev/zero`
/// (endless zeros), `/dev/urandom` (endless bytes), a FIFO with no writer (a read that never
/// returns), a directory. Each reader, reached directly or through another file, refuses it at
/// once for what it is: the scene file, an XML include, OBJ and PLY meshes, an MTL library, a
/// measured table, a direction table, the images of `diff`, a part of `merge`, the table of
/// `brdf fit` and the replay list of `stress`.
#[cfg(unix)]
#[test]
fn every_reader_refuses_what_is_not_a_regular_file() {
    let d = CLI.tmp("irregular");
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let fifo = d.join("fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let dir = d.join("a-directory");
    std::fs::create_dir(&dir).unwrap();
    let toml = |name: &str, shape: &str, material: &str| {
        let p = d.join(name);
        std::fs::write(
            &p,
            format!(
                "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 8\n\
                 height = 8\n[environment]\nradiance = 1\n[materials.m]\n{material}\n[[shapes]]\n\
                 material = \"m\"\n{shape}\n"
            ),
        )
        .unwrap();
        p
    };
    let good_png = d.join("good.png");
    let img = brdfwave::imageio::Image::filled(4, 4, [0.5; 3]);
    brdfwave::imageio::write(&good_png, &img).unwrap();
    let dirs = d.join("dirs.csv");
    std::fs::write(&dirs, "wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n0,0,1,0,0,1\n").unwrap();
    for (k, bad) in ["/dev/zero", "/dev/urandom", s(&fifo), s(&dir)]
        .into_iter()
        .enumerate()
    {
        let what = match k {
            0 | 1 => "a character device, not a regular file",
            2 => "a FIFO (named pipe), not a regular file",
            _ => "a directory, not a regular file",
        };
        let lambert = "model = \"lambert\"";
        let obj = toml(
            &format!("obj{k}.toml"),
            &format!("obj = \"{bad}\""),
            lambert,
        );
        let ply = toml(
            &format!("ply{k}.toml"),
            &format!("ply = \"{bad}\""),
            lambert,
        );
        let mtl_obj = d.join(format!("m{k}.obj"));
        std::fs::write(
            &mtl_obj,
            format!("mtllib {bad}\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        )
        .unwrap();
        let mtl = toml(
            &format!("mtl{k}.toml"),
            &format!("obj = \"m{k}.obj\"\nmtl = true"),
            lambert,
        );
        let measured = toml(
            &format!("merl{k}.toml"),
            "sphere = { center = [0, 0, 0], radius = 1 }",
            &format!("model = \"measured\"\nfile = \"{bad}\""),
        );
        let include = d.join(format!("inc{k}.xml"));
        std::fs::write(
            &include,
            format!("<scene version=\"3.0.0\"><include filename=\"{bad}\"/></scene>\n"),
        )
        .unwrap();
        let material = format!("model = \"measured\", file = \"{bad}\"");
        let fit_out = d.join(format!("fit{k}"));
        let merged = d.join("merged.exr");
        let failures = d.join("failures.jsonl");
        let runs: Vec<(Vec<&str>, &str)> = vec![
            (vec!["render", bad], "scene file"),
            (vec!["render", s(&include)], "included scene file"),
            (vec!["render", s(&obj)], "OBJ mesh"),
            (vec!["render", s(&ply)], "PLY mesh"),
            (vec!["render", s(&mtl)], "MTL library"),
            (vec!["render", s(&measured)], "measured table"),
            (
                vec!["brdf", "eval", "--material", &material, "--dirs", s(&dirs)],
                "measured table",
            ),
            (
                vec![
                    "brdf",
                    "eval",
                    "--material",
                    "model = \"lambert\"",
                    "--dirs",
                    bad,
                ],
                "CSV table",
            ),
            (vec!["merge", bad, "--out", s(&merged)], "partial film"),
            (
                vec!["brdf", "fit", "--measured", bad, "--out", s(&fit_out)],
                "measured table",
            ),
            (
                vec!["stress", "--replay", bad, "--failures", s(&failures)],
                "replay file",
            ),
        ];
        for (args, kind) in runs {
            let out = check(bin().args(&args).output().unwrap(), &format!("{args:?}"));
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}:\n{err}");
            assert!(
                err.contains(what) && err.contains(kind),
                "{args:?}: want '{what}' and '{kind}':\n{err}"
            );
        }
        // Images have an extension: a link named .exr to the device.
        let link = d.join(format!("img{k}.exr"));
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink(bad, &link).unwrap();
        fails_with(&["diff", s(&link), s(&good_png)], &[what, "image"]);
        fails_with(&["diff", s(&good_png), s(&link)], &[what, "image"]);
    }
}

/// Files over the size of their kind are refused before any of them is read (the files here
/// are sparse: they take no disk space): a 300 MiB scene file, a 9 GiB OBJ mesh.
#[test]
fn oversized_files_are_refused_before_they_are_read() {
    let d = CLI.tmp("oversized");
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let sparse = |name: &str, len: u64| {
        let p = d.join(name);
        std::fs::File::create(&p).unwrap().set_len(len).unwrap();
        p
    };
    let scene = sparse("big.toml", 300 << 20);
    fails_with(
        &["render", s(&scene)],
        &["is 300 MiB, over the 256 MiB a scene file may have"],
    );
    let xml = sparse("big.xml", 300 << 20);
    fails_with(
        &["render", s(&xml)],
        &["is 300 MiB, over the 256 MiB a scene file may have"],
    );
    sparse("big.obj", 9 << 30);
    let toml = d.join("s.toml");
    std::fs::write(
        &toml,
        "[camera]\nposition = [0, 0, 5]\ntarget = [0, 0, 0]\nfov_y = 40\n[film]\nwidth = 8\n\
         height = 8\n[materials.m]\nmodel = \"lambert\"\n[[shapes]]\nmaterial = \"m\"\nobj = \"big.obj\"\n",
    )
    .unwrap();
    fails_with(
        &["render", s(&toml)],
        &["big.obj", "is 9 GiB, over the 8 GiB an OBJ mesh may have"],
    );
    let _ = std::fs::remove_dir_all(&d);
}
