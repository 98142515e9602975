//! Link the `shaderc` crate against Debian's static shaderc/glslang libraries.
//!
//! Without `SHADERC_LIB_DIR` the `shaderc-sys` build script would compile shaderc, glslang and
//! SPIRV-Tools from C++ source (about 7 minutes on 2 cores). Debian 12's `libshaderc-dev` ships
//! `libshaderc_combined.a`, which does not contain glslang, so the glslang static libraries from
//! `glslang-dev` are linked here as well.
//! `.cargo/config.toml` sets `SHADERC_LIB_DIR` for `shaderc-sys`.
//!
//! It also embeds the GLSL sources under `shaders/` into the binary: a table of
//! `(path relative to shaders/, include_str!(...))` is written to `$OUT_DIR/embedded_shaders.rs`
//! and included by `src/vk/shader.rs`, so the binary compiles its kernels from any directory.

fn main() {
    let dir = std::env::var("SHADERC_LIB_DIR")
        .unwrap_or_else(|_| "/usr/lib/x86_64-linux-gnu".to_string());
    println!("cargo:rerun-if-env-changed=SHADERC_LIB_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-link-search=native={dir}");
    for lib in [
        "glslang",
        "MachineIndependent",
        "GenericCodeGen",
        "OSDependent",
        "OGLCompiler",
        "SPIRV",
        "SPIRV-Tools-opt",
        "SPIRV-Tools",
        "glslang-default-resource-limits",
    ] {
        println!("cargo:rustc-link-lib=static={lib}");
    }
    embed_shaders();
    git_commit();
}

/// Sets `BRDFWAVE_COMMIT` to the git commit being built (12 hex digits), or empty outside a git
/// checkout; partial films record it (`src/film/part.rs`, `code_version`) so that parts rendered
/// by different versions are not merged. Re-run when HEAD or a branch moves.
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
}

/// File endings treated as shader sources (anything else under `shaders/` is not embedded).
const SHADER_ENDINGS: [&str; 4] = ["glsl", "comp", "h", "inc"];

/// Writes `$OUT_DIR/embedded_shaders.rs`: `pub static EMBEDDED_SHADERS: &[(&str, &str)]`,
/// sorted by path, paths relative to `shaders/` with `/` separators.
fn embed_shaders() {
    use std::path::{Path, PathBuf};
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
