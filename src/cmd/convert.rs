//! `brdfwave convert SCENE --to mitsuba OUT.xml`: any scene brdfwave reads, written as a
//! Mitsuba 3 XML scene with its meshes as OBJ files in `OUT-meshes/` beside it
//! (`brdfwave::scene::mitsuba::write`); every file is written atomically.

use anyhow::{bail, Context as _, Result};
use brdfwave::outfile::{self, Output};
use brdfwave::scene::{self, mitsuba::write};
use clap::ValueEnum;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Mitsuba,
}

#[derive(clap::Args)]
pub struct ConvertArgs {
    /// The scene file (TOML or Mitsuba 3 XML).
    scene: PathBuf,
    /// The format to write.
    #[arg(long, value_enum)]
    to: Format,
    /// The file to write (.xml); the meshes go to the directory OUT-meshes beside it.
    out: PathBuf,
    /// Write the models Mitsuba lacks under brdfwave's own plugin names
    /// (`<bsdf type="ward">`): the file then loads in brdfwave only.
    #[arg(long)]
    brdfwave_plugins: bool,
    /// Set a parameter of a Mitsuba XML scene (overrides its `<default>`), like Mitsuba's -D.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = super::parse_define)]
    define: Vec<(String, String)>,
}

pub fn run(a: ConvertArgs) -> Result<()> {
    let Format::Mitsuba = a.to;
    if !scene::load::is_xml(&a.out) {
        bail!("{}: a Mitsuba scene file ends in .xml", a.out.display());
    }
    let sc = scene::load_with(&a.scene, &a.define)?;
    for w in &sc.warnings {
        eprintln!("{w}");
    }
    let stem = a
        .out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mesh_dir = format!("{stem}-meshes");
    let opts = write::Options {
        brdfwave_plugins: a.brdfwave_plugins,
        xml_dir: Some(outfile::parent_dir(&a.out).to_path_buf()),
    };
    let converted = write::to_mitsuba(&sc, &mesh_dir, opts)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.scene.display()))?;
    let dir = outfile::parent_dir(&a.out).to_path_buf();
    let mesh_paths: Vec<PathBuf> = converted.meshes.iter().map(|(n, _)| dir.join(n)).collect();
    let mut outputs = vec![Output {
        option: "OUT",
        path: &a.out,
    }];
    outputs.extend(mesh_paths.iter().map(|p| Output {
        option: "mesh",
        path: p.as_path(),
    }));
    outfile::refuse_inputs(&outputs, &[("scene file", a.scene.as_path())])?;
    outfile::prepare(&outputs)?;
    for ((_, text), path) in converted.meshes.iter().zip(&mesh_paths) {
        write_file(path, text)?;
    }
    write_file(&a.out, &converted.xml)?;
    match mesh_paths.len() {
        0 => eprintln!("wrote {}", a.out.display()),
        n => eprintln!(
            "wrote {} and {n} mesh file(s) in {}",
            a.out.display(),
            dir.join(&mesh_dir).display()
        ),
    }
    Ok(())
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    outfile::write(path, text.as_bytes()).with_context(|| format!("writing {}", path.display()))
}
