//! How the GLSL compiler (shaderc, through the `shaderc` crate) is linked, and the shaders
//! embedded.
//!
//! `shaderc-sys` (the `shaderc` crate's build script) looks for a native shaderc in this order:
//! `SHADERC_LIB_DIR`; `$VULKAN_SDK/lib`; pkg-config's `shaderc`; `/usr/lib/<arch>-linux-gnu`,
//! `/usr/lib64` or `/usr/lib`; and it links `libshaderc_combined.a` when the directory has it
//! (the `prefer-static-linking` feature), else `libshaderc.so` / `libshaderc_shared.so`. Only
//! when none is found does it compile shaderc, glslang and SPIRV-Tools from C++ source (about 7
//! minutes on 2 cores; it needs cmake, python3 and a C++ compiler).
//!
//! Debian 12's `libshaderc-dev` ships a `libshaderc_combined.a` that does not contain glslang:
//! the glslang static libraries of `glslang-dev` must be linked as well. This script finds the
//! directory shaderc-sys will use, the same way, and adds them exactly when that directory holds
//! Debian's split static libraries; with a shared or a truly combined library (a Vulkan SDK, other
//! distributions) or a source build nothing is added. A `cargo:warning` says which case it was.
//!
//! It also embeds the GLSL sources under `shaders/` into the binary: a table of
//! `(path relative to shaders/, include_str!(...))` is written to `$OUT_DIR/embedded_shaders.rs`
//! and included by `src/vk/shader.rs`, so the binary compiles its kernels from any directory.

use std::path::{Path, PathBuf};

/// The glslang static libraries Debian's `libshaderc_combined.a` leaves out, in link order.
const DEBIAN_GLSLANG: [&str; 9] = [
    "glslang",
    "MachineIndependent",
    "GenericCodeGen",
    "OSDependent",
    "OGLCompiler",
    "SPIRV",
    "SPIRV-Tools-opt",
    "SPIRV-Tools",
    "glslang-default-resource-limits",
];

fn main() {
    for var in ["SHADERC_LIB_DIR", "VULKAN_SDK", "PKG_CONFIG_PATH"] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    println!("cargo:rerun-if-changed=build.rs");
    link_debian_glslang();
    embed_shaders();
    git_commit();
}

/// The directory shaderc-sys searches for a native shaderc (its `get_search_dir`), if any.
fn shaderc_search_dir() -> Option<PathBuf> {
    if let Ok(dir) = std::env::var("SHADERC_LIB_DIR") {
        return Some(PathBuf::from(dir));
    }
    if let Ok(sdk) = std::env::var("VULKAN_SDK") {
        return Some(Path::new(&sdk).join("lib"));
    }
    let pkg = std::process::Command::new("pkg-config")
        .args(["--variable=libdir", "shaderc"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .filter(|d| !d.is_empty());
    if let Some(dir) = pkg {
        return Some(PathBuf::from(dir));
    }
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let arch = if arch == "x86" {
        "i386".to_string()
    } else {
        arch
    };
    [
        format!("/usr/lib/{arch}-linux-gnu"),
        "/usr/lib64".into(),
        "/usr/lib".into(),
    ]
    .into_iter()
    .map(PathBuf::from)
    .find(|d| d.is_dir())
}

/// Links Debian's glslang static libraries when shaderc-sys will link Debian's
/// `libshaderc_combined.a`, and says in a build note how shaderc is linked.
fn link_debian_glslang() {
    let dir = shaderc_search_dir();
    let has = |d: &Path, f: &str| d.join(f).is_file();
    match &dir {
        Some(d) if has(d, "libshaderc_combined.a") => {
            let missing: Vec<&str> = DEBIAN_GLSLANG
                .iter()
                .copied()
                .filter(|l| !has(d, &format!("lib{l}.a")))
                .collect();
            if missing.len() == DEBIAN_GLSLANG.len() {
                println!(
                    "cargo:warning=shaderc: static libshaderc_combined.a from {} (self-contained)",
                    d.display()
                );
                return;
            }
            if !missing.is_empty() {
                println!(
                    "cargo:warning=shaderc: {} has Debian's libshaderc_combined.a but not the \
                     glslang static libraries {missing:?}: install glslang-dev and spirv-tools \
                     (scripts/setup.sh), or set SHADERC_LIB_DIR to a directory with a shared \
                     libshaderc.so",
                    d.display()
                );
            }
            println!("cargo:rustc-link-search=native={}", d.display());
            for lib in DEBIAN_GLSLANG {
                println!("cargo:rustc-link-lib=static={lib}");
            }
            println!(
                "cargo:warning=shaderc: Debian's static shaderc and glslang libraries from {}",
                d.display()
            );
        }
        Some(d) if has(d, "libshaderc.so") || has(d, "libshaderc_shared.so") => println!(
            "cargo:warning=shaderc: the shared library from {} (libshaderc.so must be \
             installed where the program runs)",
            d.display()
        ),
        _ => println!(
            "cargo:warning=shaderc: no native library found, so shaderc-sys builds it from \
             source (several minutes; needs cmake, python3 and a C++ compiler)"
        ),
    }
}

/// Sets `BRDFWAVE_COMMIT` to the git commit being built (12 hex digits), or empty outside a git
/// checkout; partial films record it (`src/film/part.rs`, `code_version`) so that parts rendered
/// by different versions are not merged; and `BRDFWAVE_MODIFIED` to `modified-<hash>` when the
/// code differs from that commit. Re-run when HEAD, a branch or the code moves.
fn git_commit() {
    let git = |args: &[&str]| -> Option<String> {
        let out = std::process::Command::new("git").args(args).output().ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    };
    let commit = git(&["rev-parse", "--short=12", "HEAD"]).unwrap_or_default();
    // A missing file would make cargo re-run the script on every build: name existing ones only.
    let watch = |path: String| {
        if std::path::Path::new(&path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    };
    if let Some(dir) = git(&["rev-parse", "--absolute-git-dir"]) {
        watch(format!("{dir}/HEAD"));
    }
    if let Some(common) = git(&["rev-parse", "--path-format=absolute", "--git-common-dir"]) {
        watch(format!("{common}/refs/heads"));
        watch(format!("{common}/packed-refs"));
    }
    println!("cargo:rustc-env=BRDFWAVE_COMMIT={commit}");
    // Uncommitted changes to what the program is built from: a build of an edited tree must
    // not pass for the commit's (a binary left in target/ by an experiment could not be told
    // from main's build when a paired timing needed to; docs/bench-log.md). Named by a hash
    // of the diff, so that two different edits of one commit are told apart too. New files
    // that git does not track yet are not seen.
    let code = [
        "src",
        "shaders",
        "build.rs",
        "Cargo.toml",
        "Cargo.lock",
        ".cargo",
    ];
    for path in code {
        watch(path.to_string());
    }
    let mut args = vec!["diff", "HEAD", "--"];
    args.extend(code);
    let modified = match git(&args) {
        Some(diff) if !commit.is_empty() && !diff.is_empty() => {
            // FNV-1a, 64 bits.
            let hash = diff.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
            });
            format!("modified-{:08x}", hash >> 32)
        }
        _ => String::new(),
    };
    println!("cargo:rustc-env=BRDFWAVE_MODIFIED={modified}");
}

/// File endings treated as shader sources (anything else under `shaders/` is not embedded).
const SHADER_ENDINGS: [&str; 4] = ["glsl", "comp", "h", "inc"];

/// Writes `$OUT_DIR/embedded_shaders.rs`: `pub static EMBEDDED_SHADERS: &[(&str, &str)]`,
/// sorted by path, paths relative to `shaders/` with `/` separators.
fn embed_shaders() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let root = manifest.join("shaders");
    // A directory makes cargo rescan the whole tree for changes (added or removed files too).
    println!("cargo:rerun-if-changed=shaders");

    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) {
        let mut entries: Vec<_> = match std::fs::read_dir(dir) {
            Ok(rd) => rd.filter_map(|e| e.ok()).collect(),
            Err(e) => panic!("cannot read shader directory {}: {e}", dir.display()),
        };
        entries.sort_by_key(|e| e.file_name());
        for e in entries {
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') {
                continue;
            }
            if path.is_dir() {
                walk(root, &path, out);
            } else if SHADER_ENDINGS
                .iter()
                .any(|x| name.ends_with(&format!(".{x}")))
            {
                let rel = path.strip_prefix(root).expect("under shaders/");
                let rel: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                out.push((rel.join("/"), path));
            }
        }
    }
    let mut files = Vec::new();
    if root.is_dir() {
        walk(&root, &root, &mut files);
    }
    let mut code = String::from(
        "/// Shader sources embedded at build time by build.rs: (path relative to shaders/, text).\n\
         pub static EMBEDDED_SHADERS: &[(&str, &str)] = &[\n",
    );
    for (rel, path) in &files {
        code.push_str(&format!(
            "    ({rel:?}, include_str!({:?})),\n",
            path.display().to_string()
        ));
    }
    code.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR")).join("embedded_shaders.rs");
    // Rewrite only on change so dependent code is not rebuilt needlessly.
    if std::fs::read_to_string(&out).ok().as_deref() != Some(code.as_str()) {
        std::fs::write(&out, code).expect("write embedded_shaders.rs");
    }
}
