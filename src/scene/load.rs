//! The scene file loader: TOML text → [`Scene`] (and the dispatch to the Mitsuba 3 XML
//! reader, [`super::mitsuba`], for `.xml` files).
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
use super::error::SceneError;
use super::schema::RawScene;
use super::spanned::Cx;
use super::Scene;
use std::path::Path;

/// Largest film width or height: [`crate::conventions::MAX_FILM_SIZE`].
pub use crate::conventions::MAX_FILM_SIZE;

/// Read and load a scene file: a Mitsuba 3 XML scene when its name ends in `.xml`
/// ([`super::mitsuba`]), else TOML. Relative OBJ paths are resolved against the file's
/// directory.
///
/// A file that is not TOML but looks like another format (a pbrt scene, an OBJ or PLY mesh,
/// JSON, XML: [`super::sniff::describe`]) is refused with a message that says so.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_with(path, &[])
}

/// [`load`] with the command line's `-D name=value` parameters of a Mitsuba XML scene (they
/// override its `<default>`s); a TOML scene takes none.
pub fn load_with(path: &Path, defines: &[(String, String)]) -> Result<Scene, SceneError> {
    load_read(path, defines).map(|(scene, _)| scene)
}

/// [`load_with`], and the bytes of the file it read (the file is read once).
pub fn load_read(
    path: &Path,
    defines: &[(String, String)],
) -> Result<(Scene, Vec<u8>), SceneError> {
    let read_error = |source| SceneError::Read {
        file: crate::errors::shown_path(path),
        source,
    };
    let bytes = crate::infile::read(path, crate::infile::SCENE).map_err(read_error)?;
    // Binary content (a binary PLY mesh, say) fails as UTF-8 before it can fail as TOML.
    let source = crate::errors::utf8_of(&bytes)
        .map_err(|e| wrong_format(&bytes, path).unwrap_or_else(|| read_error(e)))?;
    let scene = load_str_with(source, path, defines)?;
    Ok((scene, bytes))
}

/// Whether `path` names a Mitsuba XML scene (by its extension, `.xml` in any case).
pub fn is_xml(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// [`load_str`] with `-D name=value` parameters (Mitsuba XML scenes only).
pub fn load_str_with(
    source: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<Scene, SceneError> {
    if is_xml(path) {
        return super::mitsuba::load_str(source, path, defines);
    }
    if let Some((name, _)) = defines.first() {
        return Err(SceneError::Invalid {
            file: crate::errors::shown_path(path),
            line: None,
            field: None,
            message: format!(
                "-D {name}=…: parameters apply to Mitsuba XML scenes only (this is a TOML scene)"
            ),
        });
    }
    load_str(source, path)
}

/// The error for a file that looks like another format, if it does: not for XML in a file
/// named `.xml`, which is the format its name says (the XML reader's own message, located,
/// is the one to give).
fn wrong_format(bytes: &[u8], path: &Path) -> Option<SceneError> {
    let kind = super::sniff::describe(bytes)?;
    if is_xml(path) && super::sniff::is_xml_kind(kind) {
        return None;
    }
    let mesh = if kind.ends_with("mesh") {
        " (a mesh goes into a scene as a shape: `obj = \"mesh.obj\"` in a [[shapes]] table)"
    } else {
        ""
    };
    Some(SceneError::Invalid {
        file: crate::errors::shown_path(path),
        line: None,
        field: None,
        message: format!(
            "this looks like {kind}, not a scene file: {}{mesh}",
            super::sniff::READS
        ),
    })
}

/// Load a scene from its text. `path` names the scene in messages and its parent directory
/// is where relative OBJ paths are looked up; the file itself is not read.
///
/// Legal but suspicious content (unused materials, skipped zero-area OBJ triangles, ignored
/// MTL files, …) is reported in [`Scene::warnings`].
pub fn load_str(source: &str, path: &Path) -> Result<Scene, SceneError> {
    if is_xml(path) {
        return super::mitsuba::load_str(source, path, &[]);
    }
    let mut cx = Cx::new(crate::errors::shown_path(path), source);
    cx.dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let raw: RawScene = toml::from_str(source)
        .map_err(|e| wrong_format(source.as_bytes(), path).unwrap_or_else(|| cx.toml_error(&e)))?;
    build(&mut cx, raw, path)
}
