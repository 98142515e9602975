//! The scene file loader: TOML text → [`Scene`].
//!
//! The format is documented field by field in `scenes/README.md`. Loading happens in two
//! steps, each in its own file: serde reads the text into the raw form of
//! [`super::schema`] (every value wrapped in [`super::spanned::Sp`] so that its line is known),
//! then [`super::assemble`] checks the values and builds the flat primitive lists of
//! [`Scene`], reading OBJ meshes with [`super::obj`].
//!
//! Every error names the file and, when they exist, the line and the dotted field path
//! (`box.toml:12: field 'shapes[3].sphere.radius': -1 is out of range …`); serde errors are
//! located by [`super::spanned`]. Loading never panics on any input.

use super::assemble::build;
use super::schema::RawScene;
use super::spanned::Cx;
use super::Scene;
use crate::brdf::ParamError;
use std::path::Path;

/// Largest accepted film width or height in pixels.
pub const MAX_FILM_SIZE: u32 = 16384;

/// Why a scene could not be loaded. The `Display` text always starts with the scene file's
/// name, followed by the line and the field when they are known:
/// `file:line: field 'a.b': what is wrong`.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file itself could not be read.
    #[error("{file}: cannot read the scene file: {source}")]
    Read {
        file: String,
        #[source]
        source: std::io::Error,
    },
    /// Anything wrong with the contents: syntax, types, values, referenced OBJ files.
    #[error("{}", located(file, *line, field.as_deref(), message))]
    Invalid {
        file: String,
        /// 1-based line in the scene file.
        line: Option<usize>,
        /// Dotted path of the offending field, e.g. `shapes[2].sphere.radius`
        /// (array indices are 0-based, in file order).
        field: Option<String>,
        message: String,
    },
    /// A material's parameters are wrong; the message (from [`crate::brdf`]) is already
    /// `file:line: material 'name', field 'f': …`.
    #[error(transparent)]
    Material(#[from] ParamError),
}

fn located(file: &str, line: Option<usize>, field: Option<&str>, message: &str) -> String {
    let mut s = file.to_string();
    if let Some(l) = line {
        s.push_str(&format!(":{l}"));
    }
    s.push_str(": ");
    if let Some(f) = field {
        s.push_str(&format!("field '{f}': "));
    }
    s.push_str(message);
    s
}

/// Read and load a scene file. Relative OBJ paths are resolved against the file's directory.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let source = crate::errors::read_utf8(path).map_err(|source| SceneError::Read {
        file: path.display().to_string(),
        source,
    })?;
    load_str(&source, path)
}

/// Load a scene from its text. `path` names the scene in messages and its parent directory
/// is where relative OBJ paths are looked up; the file itself is not read.
///
/// Legal but suspicious content (unused materials, skipped zero-area OBJ triangles, ignored
/// MTL files, …) is reported in [`Scene::warnings`].
pub fn load_str(source: &str, path: &Path) -> Result<Scene, SceneError> {
    let mut cx = Cx {
        file: path.display().to_string(),
        source,
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        warnings: Vec::new(),
    };
    let raw: RawScene = toml::from_str(source).map_err(|e| cx.toml_error(&e))?;
    build(&mut cx, raw, path)
}
