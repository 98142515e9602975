//! The Mitsuba 3 peer: [`MitsubaRunner`] drives `scripts/mitsuba_peer.py` (embedded) over
//! its line protocol, on the scene as `brdfwave convert --to mitsuba` writes it; libLLVM
//! discovery for Dr.Jit.

use super::runner::Runner;
use super::Details;
use crate::imageio::{self, Image};
use anyhow::{anyhow, bail, Context as _, Result};
use std::io::{BufRead, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};

/// The Mitsuba side of the peer configurations (see its docstring for the protocol).
const MITSUBA_SCRIPT: &str = include_str!("../../scripts/mitsuba_peer.py");

pub(super) struct MitsubaRunner {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    last: Option<PathBuf>,
    variant: String,
    sampler: String,
    setup_seconds: f64,
    compile_seconds: f64,
    plain: (u32, f64),
    spp: u32,
}

impl MitsubaRunner {
    pub(super) fn start(
        variant: &str,
        sampler: &str,
        scene_xml: &Path,
        dir: &Path,
    ) -> Result<MitsubaRunner> {
        let script = dir.join("mitsuba_peer.py");
        std::fs::write(&script, MITSUBA_SCRIPT)
            .with_context(|| format!("writing {}", script.display()))?;
        let mut cmd = Command::new("python3");
        cmd.arg(&script)
            .arg(variant)
            .arg(sampler)
            .arg(scene_xml)
            .arg(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        // Dr.Jit's LLVM backend needs LLVM 16 or newer; LLVM 15 (lavapipe's) crashes it.
        if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
            if let Some(p) = newest_libllvm() {
                cmd.env("DRJIT_LIBLLVM_PATH", p);
            }
        }
        let mut child = cmd.spawn().context("starting python3")?;
        let stdin = child.stdin.take().expect("piped");
        let mut stdout = BufReader::new(child.stdout.take().expect("piped"));
        let line = protocol_line(&mut stdout)?;
        let line = line.trim();
        if let Some(msg) = line.strip_prefix("error ") {
            let _ = child.kill();
            let _ = child.wait();
            bail!("{msg}");
        }
        // `ready COMPILE_SECONDS PLAIN_SPP PLAIN_SECONDS LOAD_SECONDS`.
        let w: Vec<&str> = line.split_whitespace().collect();
        let num = |s: &str| s.parse::<f64>().ok();
        let ready = match w[..] {
            ["ready", c, n, s, l] => match (num(c), n.parse::<u32>().ok(), num(s), num(l)) {
                (Some(c), Some(n), Some(s), Some(l)) => Some((c, (n, s), l)),
                _ => None,
            },
            _ => None,
        };
        let Some((compile_seconds, plain, load_seconds)) = ready else {
            let _ = child.kill();
            let _ = child.wait();
            bail!("the Mitsuba script ended without a word (is python3 with mitsuba installed?)");
        };
        Ok(MitsubaRunner {
            child,
            stdin,
            stdout,
            last: None,
            variant: variant.to_string(),
            sampler: sampler.to_string(),
            setup_seconds: load_seconds,
            compile_seconds,
            plain,
            spp: 0,
        })
    }
}

impl Runner for MitsubaRunner {
    fn pass(&mut self, n: u32) -> Result<(u32, f64)> {
        // A fresh render of all the samples so far (see the module docs).
        writeln!(
            self.stdin,
            "render {} {}",
            self.spp + n,
            super::REPEAT_BELOW
        )?;
        self.stdin.flush()?;
        let line = protocol_line(&mut self.stdout)?;
        let mut w = line.split_whitespace();
        match (w.next(), w.next(), w.next(), w.next(), w.next()) {
            (Some("done"), Some(secs), Some(spp), Some(compile), Some(path)) => {
                self.last = Some(PathBuf::from(path));
                self.spp = spp.parse()?;
                self.compile_seconds += compile.parse::<f64>()?;
                Ok((self.spp, secs.parse()?))
            }
            _ => bail!(
                "Mitsuba ({}, {}) answered '{}'",
                self.variant,
                self.sampler,
                line.trim()
            ),
        }
    }
    fn image(&mut self) -> Result<Image> {
        let p = self.last.as_ref().ok_or_else(|| anyhow!("no pass yet"))?;
        Ok(imageio::read(p)?)
    }
    fn details(&mut self) -> Details {
        Details {
            device: format!("Mitsuba 3 {}", self.variant),
            setup_seconds: self.setup_seconds,
            peer_compile: Some(self.compile_seconds),
            peer_plain: Some(self.plain),
            ..Default::default()
        }
    }
}

impl Drop for MitsubaRunner {
    fn drop(&mut self) {
        let _ = writeln!(self.stdin, "quit");
        let _ = self.stdin.flush();
        let _ = self.child.wait();
    }
}

/// The next line of the Mitsuba script's protocol (`ready`, `done` or `error`), skipping any
/// other output (a log line the script did not silence); "" at the end of its output.
fn protocol_line(r: &mut impl BufRead) -> Result<String> {
    for _ in 0..10_000 {
        let mut line = String::new();
        if r.read_line(&mut line)? == 0 {
            return Ok(line);
        }
        if ["ready", "done", "error"]
            .iter()
            .any(|w| line.split_whitespace().next() == Some(*w))
        {
            return Ok(line);
        }
    }
    bail!("the Mitsuba script wrote 10000 lines that are not its protocol")
}

/// A libLLVM of version 16 or later for Dr.Jit: the newest one on the system, else the Rust
/// toolchain's own (`rustc --print sysroot`, `lib/libLLVM*.so*`), which every brdfwave build
/// has and which Dr.Jit accepts. Debian 12's own is LLVM 15.
fn newest_libllvm() -> Option<PathBuf> {
    let dir = Path::new("/usr/lib/x86_64-linux-gnu");
    let system = (16..=30)
        .rev()
        .flat_map(|v| [format!("libLLVM.so.{v}.1"), format!("libLLVM-{v}.so")])
        .map(|n| dir.join(n))
        .find(|p| p.exists());
    system.or_else(rust_toolchain_libllvm)
}

/// The Rust toolchain's libLLVM (rustup's toolchains bundle a recent LLVM: Rust 1.95's is
/// LLVM 22), if `rustc` runs and its sysroot has one.
fn rust_toolchain_libllvm() -> Option<PathBuf> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .stderr(Stdio::null())
        .output()
        .ok()
        .filter(|o| o.status.success())?;
    let lib = Path::new(String::from_utf8(out.stdout).ok()?.trim()).join("lib");
    // The shared object itself: beside it, `libLLVM-NN-rust-*.so` is a linker script.
    let is_elf = |p: &Path| {
        let mut magic = [0u8; 4];
        std::fs::File::open(p)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic))
            .is_ok_and(|_| magic == *b"\x7fELF")
    };
    let mut found: Vec<PathBuf> = std::fs::read_dir(lib)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("libLLVM") && n.contains(".so"))
                && is_elf(p)
        })
        .collect();
    found.sort();
    found.into_iter().next()
}

/// Whether `python3 -c "import mitsuba"` works.
pub(super) fn mitsuba_installed() -> bool {
    Command::new("python3")
        .args(["-c", "import mitsuba"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}
