//! GLSL → SPIR-V compilation through shaderc at run time, with an on-disk SPIR-V cache.
//!
//! Sources come from the copy of `shaders/` embedded in the binary by `build.rs`, or, when the
//! environment variable `BRDFWAVE_SHADER_DIR` is set, from that directory (edit shaders without
//! rebuilding). `#include "x"` names are relative to the shader root, never to the including
//! file. *Overrides* map a virtual include name to a real file, so that one kernel template
//! (`#include "brdf/model.glsl"`) serves every reflectance model. *Generated* sources
//! ([`ShaderCompiler::compile_generated`]) are headers written by the caller for one
//! compilation, e.g. the wavefront kernels' interface generated from `gpu::layout`.
//!
//! Compiled modules are cached under `<cache>/spirv/<key>.spv`, where `<key>` is a 64-bit FNV-1a
//! hash of every source file the shader can read (found by following the `#include` lines
//! ourselves, through the overrides), the defines, the overrides, the compile options and a
//! format version. A cache hit costs a hash of the sources and one file read; nothing is
//! compiled. Entries are written atomically and checked on read (magic, key, length, checksum),
//! so a damaged entry is recompiled, not used.

use super::cache::{default_cache_dir, write_atomic};
use crate::hash::{fnv1a64, Fnv64};
use anyhow::{anyhow, bail, Context as _, Result};
use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

include!(concat!(env!("OUT_DIR"), "/embedded_shaders.rs"));

/// Environment variable naming a shader root directory to read instead of the embedded copy.
pub const SHADER_DIR_ENV: &str = "BRDFWAVE_SHADER_DIR";

/// Bump when the cache file layout or anything else that changes the output without changing
/// the hashed inputs changes (e.g. the compile options below).
const CACHE_FORMAT_VERSION: u64 = 1;
/// The compile options, hashed into the cache key.
const OPTIONS_TAG: &str = "glsl compute main; vulkan1.2; spirv1.5; opt=performance";
const CACHE_MAGIC: &[u8; 8] = b"BWSPIRV1";
/// The first word of every SPIR-V module (SPIR-V specification, section 2.3).
pub(crate) const SPIRV_MAGIC: u32 = 0x0723_0203;
/// Deeper include nesting than this is taken to be an include cycle without a guard.
const MAX_INCLUDE_DEPTH: usize = 32;

/// Where shader sources are read from.
#[derive(Clone, Debug)]
enum Source {
    Embedded,
    Dir(PathBuf),
}

/// Counters of [`ShaderCompiler::compile`] calls, for reporting compile time against cache hits.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CompileStats {
    /// Modules compiled by shaderc.
    pub compiled: u32,
    /// Modules loaded from the SPIR-V cache.
    pub cache_hits: u32,
    /// Cache entries found damaged (and recompiled).
    pub corrupt_entries: u32,
    /// Cache writes that failed (the module was still returned).
    pub cache_write_failures: u32,
    /// Wall time spent compiling with shaderc (includes hashing and writing the cache).
    pub compile_seconds: f64,
    /// Wall time spent on cache hits (hashing the sources and reading the entry).
    pub cache_seconds: f64,
}

/// One compiled module and how it was obtained.
#[derive(Clone, Debug)]
pub struct CompiledShader {
    pub spirv: Vec<u32>,
    /// The cache key (FNV-1a 64 of sources, defines, overrides and options).
    pub key: u64,
    pub from_cache: bool,
    pub seconds: f64,
}

/// Compiles GLSL compute shaders with shaderc (Vulkan 1.2, SPIR-V 1.5, optimised for
/// performance). One instance can be shared by several threads.
pub struct ShaderCompiler {
    compiler: shaderc::Compiler,
    source: Source,
    /// In-memory files that shadow the shader root (see [`ShaderCompiler::with_source`]).
    extra: Vec<(String, String)>,
    cache_dir: Option<PathBuf>,
    stats: Mutex<CompileStats>,
}

/// What one compilation reads besides the shader tree: its top file (normalised), the defines,
/// the include overrides (normalised) and the generated files; the cache key hashes all of it.
struct Inputs<'a> {
    top: &'a str,
    defines: &'a [(String, String)],
    overrides: &'a [(String, String)],
    generated: &'a [(String, String)],
}

impl ShaderCompiler {
    /// Sources from `$BRDFWAVE_SHADER_DIR` when set, else the embedded copy; the cache in
    /// [`default_cache_dir`] (`$BRDFWAVE_CACHE_DIR`, `$XDG_CACHE_HOME/brdfwave` or
    /// `$HOME/.cache/brdfwave`).
    pub fn new() -> Result<Self> {
        let compiler = shaderc::Compiler::new()
            .map_err(|e| anyhow!("initialising the shaderc compiler: {e}"))?;
        let source = match std::env::var_os(SHADER_DIR_ENV).filter(|v| !v.is_empty()) {
            Some(dir) => {
                let dir = PathBuf::from(dir);
                if !dir.is_dir() {
                    bail!("{SHADER_DIR_ENV}={} is not a directory", dir.display());
                }
                Source::Dir(dir)
            }
            None => Source::Embedded,
        };
        Ok(ShaderCompiler {
            compiler,
            source,
            extra: crate::brdf::glsl::sources(),
            cache_dir: default_cache_dir(),
            stats: Mutex::new(CompileStats::default()),
        })
    }

    /// Read sources from `dir` instead (same layout as `shaders/`).
    pub fn with_shader_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.source = Source::Dir(dir.into());
        self
    }

    /// Read sources from the copy embedded at build time, whatever `$BRDFWAVE_SHADER_DIR` says.
    pub fn with_embedded_shaders(mut self) -> Self {
        self.source = Source::Embedded;
        self
    }

    /// Adds an in-memory source file `path` (relative to the shader root) that shadows any file
    /// of that name: generated code, or test kernels that include the real shaders.
    pub fn with_source(mut self, path: &str, text: &str) -> Result<Self> {
        let name = normalize(path)?;
        self.extra.retain(|(p, _)| *p != name);
        self.extra.push((name, text.to_string()));
        Ok(self)
    }

    /// Cache SPIR-V under `dir/spirv/` instead of the default cache directory.
    pub fn with_cache_dir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.cache_dir = Some(dir.into());
        self
    }

    /// Never read or write the SPIR-V cache.
    pub fn without_cache(mut self) -> Self {
        self.cache_dir = None;
        self
    }

    /// The SPIR-V cache directory in use, if any.
    pub fn spirv_cache_dir(&self) -> Option<PathBuf> {
        self.cache_dir.as_ref().map(|d| d.join("spirv"))
    }

    /// Where sources come from, in words (for logs).
    pub fn source_description(&self) -> String {
        match &self.source {
            Source::Embedded => {
                format!("{} shaders embedded at build time", EMBEDDED_SHADERS.len())
            }
            Source::Dir(d) => format!("{SHADER_DIR_ENV}={}", d.display()),
        }
    }

    /// Counters since creation (or the last [`reset_stats`](Self::reset_stats)).
    pub fn stats(&self) -> CompileStats {
        self.stats.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    pub fn reset_stats(&self) {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner()) = CompileStats::default();
    }

    /// The text of a source file, `path` relative to the shader root.
    pub fn read_source(&self, path: &str) -> Result<String> {
        self.read_source_in(path, &[])
    }

    /// The text of a source file, from `generated` (name, text) first.
    fn read_source_in(&self, path: &str, generated: &[(String, String)]) -> Result<String> {
        let name = normalize(path)?;
        if let Some((_, text)) = generated.iter().find(|(p, _)| *p == name) {
            return Ok(text.clone());
        }
        if let Some((_, text)) = self.extra.iter().find(|(p, _)| *p == name) {
            return Ok(text.clone());
        }
        match &self.source {
            Source::Embedded => EMBEDDED_SHADERS
                .iter()
                .find(|(p, _)| *p == name)
                .map(|(_, text)| text.to_string())
                .ok_or_else(|| {
                    anyhow!(
                        "shader source \"{name}\" is not among the {} files embedded from shaders/ at build time",
                        EMBEDDED_SHADERS.len()
                    )
                }),
            Source::Dir(dir) => {
                let file = dir.join(&name);
                std::fs::read_to_string(&file).with_context(|| format!("reading shader source {}", file.display()))
            }
        }
    }

    /// Compile `path` (relative to the shader root, e.g. `"wavefront/extend.comp"`) to SPIR-V.
    /// `defines` become `#define NAME VALUE`; `overrides` map virtual include names to real files,
    /// e.g. `("brdf/model.glsl", "brdf/ward.glsl")`.
    pub fn compile(
        &self,
        path: &str,
        defines: &[(String, String)],
        overrides: &[(String, String)],
    ) -> Result<Vec<u32>> {
        Ok(self.compile_detailed(path, defines, overrides)?.spirv)
    }

    /// [`compile`](Self::compile), also saying whether the module came from the cache.
    pub fn compile_detailed(
        &self,
        path: &str,
        defines: &[(String, String)],
        overrides: &[(String, String)],
    ) -> Result<CompiledShader> {
        self.compile_generated(path, defines, overrides, &[])
    }

    /// [`compile_detailed`](Self::compile_detailed) with `generated` (path, text) source files
    /// that shadow any file of that name for this compilation only (and are hashed into the
    /// cache key like any source): headers generated from a description in Rust, such as the
    /// wavefront kernels' interface (`gpu::layout::glsl`).
    pub fn compile_generated(
        &self,
        path: &str,
        defines: &[(String, String)],
        overrides: &[(String, String)],
        generated: &[(String, String)],
    ) -> Result<CompiledShader> {
        let generated: Vec<(String, String)> = generated
            .iter()
            .map(|(p, t)| Ok((normalize(p)?, t.clone())))
            .collect::<Result<_>>()?;
        let generated = &generated[..];
        let start = Instant::now();
        let top = normalize(path)?;
        for (name, value) in defines {
            check_define(name, value).with_context(|| format!("compiling shader {top}"))?;
        }
        let overrides =
            normalize_overrides(overrides).with_context(|| format!("compiling shader {top}"))?;
        let inputs = Inputs {
            top: &top,
            defines,
            overrides: &overrides,
            generated,
        };
        let key = self.cache_key(&inputs)?;
        let entry = self
            .spirv_cache_dir()
            .map(|d| d.join(format!("{key:016x}.spv")));

        if let Some(entry) = &entry {
            match std::fs::read(entry) {
                Ok(bytes) => match decode_cache_entry(&bytes, key) {
                    Some(spirv) => {
                        let seconds = start.elapsed().as_secs_f64();
                        let mut s = self.stats.lock().unwrap_or_else(|e| e.into_inner());
                        s.cache_hits += 1;
                        s.cache_seconds += seconds;
                        return Ok(CompiledShader {
                            spirv,
                            key,
                            from_cache: true,
                            seconds,
                        });
                    }
                    None => {
                        self.stats
                            .lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .corrupt_entries += 1
                    }
                },
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(_) => {
                    self.stats
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .corrupt_entries += 1
                }
            }
        }

        let spirv = self.compile_uncached(&inputs)?;
        let mut write_failed = false;
        if let Some(entry) = &entry {
            if let Err(e) = write_atomic(entry, &encode_cache_entry(&spirv, key)) {
                write_failed = true;
                eprintln!(
                    "warning: could not write the SPIR-V cache entry {}: {}",
                    entry.display(),
                    crate::errors::chain(&e)
                );
            }
        }
        let seconds = start.elapsed().as_secs_f64();
        let mut s = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        s.compiled += 1;
        s.compile_seconds += seconds;
        s.cache_write_failures += write_failed as u32;
        Ok(CompiledShader {
            spirv,
            key,
            from_cache: false,
            seconds,
        })
    }

    /// Resolve an include name through the overrides (one level, no chains).
    fn resolve<'o>(name: &'o str, overrides: &'o [(String, String)]) -> &'o str {
        overrides
            .iter()
            .find(|(v, _)| v == name)
            .map(|(_, r)| r.as_str())
            .unwrap_or(name)
    }

    /// The cache key: every file reachable through `#include` lines (followed here, through the
    /// overrides; lines inside `#if` blocks count too, which can only add inputs), the defines,
    /// the overrides and the options.
    fn cache_key(&self, i: &Inputs) -> Result<u64> {
        let top = i.top;
        let mut h = Fnv64::new();
        h.str("brdfwave-spirv")
            .u64(CACHE_FORMAT_VERSION)
            .str(OPTIONS_TAG)
            .str(top);
        let top_text = self
            .read_source_in(top, i.generated)
            .with_context(|| format!("compiling shader {top}"))?;
        h.str(&top_text);
        // Depth first, in include order, each file once: the hash is a deterministic function of
        // the sources.
        let mut seen: HashSet<String> = HashSet::from([top.to_string()]);
        let mut stack: Vec<String> = vec![top_text];
        while let Some(text) = stack.pop() {
            let mut children = Vec::new();
            for inc in include_names(&text) {
                let Ok(requested) = normalize(&inc) else {
                    // shaderc reports the bad name if the line is really reached.
                    h.u64(2).str(&inc);
                    continue;
                };
                let resolved = Self::resolve(&requested, i.overrides).to_string();
                if !seen.insert(resolved.clone()) {
                    continue;
                }
                h.str(&requested).str(&resolved);
                match self.read_source_in(&resolved, i.generated) {
                    Ok(t) => {
                        h.u64(1).str(&t);
                        children.push(t);
                    }
                    // A missing file is an error only if the include is really reached (it may
                    // sit in an inactive #if block); shaderc then reports it.
                    Err(_) => {
                        h.u64(0);
                    }
                }
            }
            stack.extend(children.into_iter().rev());
        }
        h.u64(i.defines.len() as u64);
        for (n, v) in i.defines {
            h.str(n).str(v);
        }
        h.u64(i.overrides.len() as u64);
        for (v, r) in i.overrides {
            h.str(v).str(r);
        }
        Ok(h.finish())
    }

    fn compile_uncached(&self, i: &Inputs) -> Result<Vec<u32>> {
        let top = i.top;
        let text = self.read_source_in(top, i.generated)?;
        let mut opts =
            shaderc::CompileOptions::new().map_err(|e| anyhow!("creating shaderc options: {e}"))?;
        opts.set_source_language(shaderc::SourceLanguage::GLSL);
        opts.set_target_env(
            shaderc::TargetEnv::Vulkan,
            shaderc::EnvVersion::Vulkan1_2 as u32,
        );
        opts.set_target_spirv(shaderc::SpirvVersion::V1_5);
        opts.set_optimization_level(shaderc::OptimizationLevel::Performance);
        for (name, value) in i.defines {
            opts.add_macro_definition(name, Some(value));
        }
        opts.set_include_callback(|requested, _kind, requester, depth| {
            if depth > MAX_INCLUDE_DEPTH {
                return Err(format!(
                    "#include \"{requested}\" in {requester}: nesting deeper than {MAX_INCLUDE_DEPTH} (an include cycle without an include guard?)"
                ));
            }
            let name = normalize(requested).map_err(|e| format!("#include \"{requested}\" in {requester}: {e}"))?;
            let real = Self::resolve(&name, i.overrides);
            let via = if real != name { format!(" (override of \"{name}\")") } else { String::new() };
            match self.read_source_in(real, i.generated) {
                Ok(content) => Ok(shaderc::ResolvedInclude { resolved_name: real.to_string(), content }),
                Err(e) => Err(format!("#include \"{requested}\" in {requester}{via}: {e:#}")),
            }
        });
        let describe = || {
            let mut s = String::new();
            if !i.defines.is_empty() {
                let d: Vec<String> = i.defines.iter().map(|(n, v)| format!("{n}={v}")).collect();
                s += &format!("; defines: {}", d.join(" "));
            }
            if !i.overrides.is_empty() {
                let o: Vec<String> = i
                    .overrides
                    .iter()
                    .map(|(v, r)| format!("{v}->{r}"))
                    .collect();
                s += &format!("; overrides: {}", o.join(" "));
            }
            s
        };
        let artifact = self
            .compiler
            .compile_into_spirv(
                &text,
                shaderc::ShaderKind::Compute,
                top,
                "main",
                Some(&opts),
            )
            .map_err(|e| match e {
                shaderc::Error::CompilationError(n, msg) => {
                    anyhow!(
                        "{n} error(s) compiling shader {top}{}:\n{}",
                        describe(),
                        msg.trim_end()
                    )
                }
                other => anyhow!("compiling shader {top}{}: {other}", describe()),
            })?;
        if artifact.get_num_warnings() > 0 {
            eprintln!(
                "warning: shader {top}{}:\n{}",
                describe(),
                artifact.get_warning_messages().trim_end()
            );
        }
        let spirv = artifact.as_binary().to_vec();
        if spirv.first() != Some(&SPIRV_MAGIC) {
            bail!("shaderc returned a module without the SPIR-V magic number for {top}");
        }
        Ok(spirv)
    }
}

/// Normalises a root-relative shader path: `/` separators, no `.` parts; `..` may not leave the
/// root and absolute paths are refused.
fn normalize(path: &str) -> Result<String> {
    if path.is_empty() {
        bail!("empty shader path");
    }
    if path.starts_with('/') || path.contains('\\') || path.contains('\0') {
        bail!("shader path \"{path}\" must be relative to the shader root, with '/' separators");
    }
    let mut parts: Vec<&str> = Vec::new();
    for part in path.split('/') {
        match part {
            "" | "." => {}
            ".." => {
                if parts.pop().is_none() {
                    bail!("shader path \"{path}\" leaves the shader root");
                }
            }
            p => parts.push(p),
        }
    }
    if parts.is_empty() {
        bail!("shader path \"{path}\" names no file");
    }
    Ok(parts.join("/"))
}

fn normalize_overrides(overrides: &[(String, String)]) -> Result<Vec<(String, String)>> {
    let mut out: Vec<(String, String)> = Vec::with_capacity(overrides.len());
    for (v, r) in overrides {
        let (nv, nr) = (normalize(v)?, normalize(r)?);
        if let Some((_, prev)) = out.iter().find(|(x, _)| *x == nv) {
            if *prev != nr {
                bail!("include override \"{v}\" is given twice (\"{prev}\" and \"{r}\")");
            }
            continue;
        }
        out.push((nv, nr));
    }
    Ok(out)
}

fn check_define(name: &str, value: &str) -> Result<()> {
    let mut chars = name.chars();
    let ok_start = chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_');
    if !ok_start || !chars.all(|c| c.is_ascii_alphanumeric() || c == '_') {
        bail!("define name \"{name}\" is not a C identifier");
    }
    if value.contains('\n') || value.contains('\r') || value.contains('\0') {
        bail!("define {name} has a value with a line break or NUL: {value:?}");
    }
    Ok(())
}

/// The names in the `#include "x"` / `#include <x>` lines of `text`, in order.
fn include_names(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let Some(rest) = line.trim_start().strip_prefix('#') else {
            continue;
        };
        let Some(rest) = rest.trim_start().strip_prefix("include") else {
            continue;
        };
        let rest = rest.trim_start();
        let close = match rest.chars().next() {
            Some('"') => '"',
            Some('<') => '>',
            _ => continue,
        };
        if let Some(end) = rest[1..].find(close) {
            out.push(rest[1..1 + end].to_string());
        }
    }
    out
}

/// Cache entry layout (little endian): magic "BWSPIRV1", key u64, word count u64, FNV-1a 64 of the
/// payload bytes u64, payload.
fn encode_cache_entry(spirv: &[u32], key: u64) -> Vec<u8> {
    let payload: Vec<u8> = spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
    let mut out = Vec::with_capacity(32 + payload.len());
    out.extend_from_slice(CACHE_MAGIC);
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&(spirv.len() as u64).to_le_bytes());
    out.extend_from_slice(&fnv1a64(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// The module in a cache entry, or `None` when anything about it is wrong.
fn decode_cache_entry(bytes: &[u8], key: u64) -> Option<Vec<u32>> {
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap());
    if bytes.len() < 32 || &bytes[..8] != CACHE_MAGIC || u64_at(8) != key {
        return None;
    }
    let words = u64_at(16) as usize;
    let payload = &bytes[32..];
    if words.checked_mul(4) != Some(payload.len()) || words < 5 || u64_at(24) != fnv1a64(payload) {
        return None;
    }
    let spirv: Vec<u32> = payload
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    (spirv[0] == SPIRV_MAGIC).then_some(spirv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn normalize_paths() {
        assert_eq!(normalize("brdf/./ward.glsl").unwrap(), "brdf/ward.glsl");
        assert_eq!(normalize("brdf/../common.glsl").unwrap(), "common.glsl");
        assert!(normalize("../x.glsl").is_err());
        assert!(normalize("/abs.glsl").is_err());
        assert!(normalize("").is_err());
    }

    #[test]
    fn include_lines_are_found() {
        let t = "#version 450\n  #  include \"a/b.glsl\" // c\n#include <c.glsl>\n// #include \"no\"\n#define X\n";
        assert_eq!(
            include_names(t),
            vec!["a/b.glsl".to_string(), "c.glsl".to_string()]
        );
    }

    #[test]
    fn defines_are_checked() {
        assert!(check_define("BRDF_EVAL", "ward_eval").is_ok());
        assert!(check_define("1X", "1").is_err());
        assert!(check_define("A B", "1").is_err());
        assert!(check_define("X", "1\n#define Y").is_err());
    }

    #[test]
    fn cache_entry_round_trip_and_corruption() {
        let spirv = vec![SPIRV_MAGIC, 0x0001_0500, 0, 10, 0, 7, 8, 9];
        let bytes = encode_cache_entry(&spirv, 42);
        assert_eq!(decode_cache_entry(&bytes, 42), Some(spirv.clone()));
        assert_eq!(decode_cache_entry(&bytes, 43), None, "wrong key");
        assert_eq!(
            decode_cache_entry(&bytes[..bytes.len() - 4], 42),
            None,
            "truncated"
        );
        let mut flipped = bytes.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert_eq!(decode_cache_entry(&flipped, 42), None, "payload bit flip");
        assert_eq!(decode_cache_entry(b"garbage", 42), None);
    }

    #[test]
    fn embedded_table_holds_the_source_tree() {
        // Every embedded file is the current text of the file in shaders/.
        assert!(!EMBEDDED_SHADERS.is_empty());
        for (rel, text) in EMBEDDED_SHADERS {
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
            let on_disk = std::fs::read_to_string(root.join(rel)).unwrap();
            assert_eq!(&on_disk, text, "{rel}");
        }
        assert!(EMBEDDED_SHADERS.iter().any(|(p, _)| *p == "common.glsl"));
        // And every shader source on disk is embedded (the table is not stale).
        fn walk(dir: &Path, prefix: &str, out: &mut Vec<String>) {
            for e in std::fs::read_dir(dir).unwrap() {
                let e = e.unwrap();
                let name = e.file_name().to_string_lossy().into_owned();
                if e.path().is_dir() {
                    walk(&e.path(), &format!("{prefix}{name}/"), out);
                } else if name.ends_with(".glsl") || name.ends_with(".comp") {
                    out.push(format!("{prefix}{name}"));
                }
            }
        }
        let mut on_disk = Vec::new();
        walk(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders"),
            "",
            &mut on_disk,
        );
        for rel in on_disk {
            assert!(
                EMBEDDED_SHADERS.iter().any(|(p, _)| *p == rel),
                "{rel} is not embedded"
            );
        }
    }
}
