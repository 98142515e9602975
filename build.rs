//! Link the `shaderc` crate against Debian's static shaderc/glslang libraries.
//!
//! Without `SHADERC_LIB_DIR` the `shaderc-sys` build script would compile shaderc, glslang and
//! SPIRV-Tools from C++ source (about 7 minutes on 2 cores). Debian 12's `libshaderc-dev` ships
//! `libshaderc_combined.a`, which does not contain glslang, so the glslang static libraries from
//! `glslang-dev` are linked here as well (see the renderer anchors, takeaway 10).
//! `.cargo/config.toml` sets `SHADERC_LIB_DIR` for `shaderc-sys`.

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
}
