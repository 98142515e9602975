//! Mitsuba 3 XML scenes: the common subset (documented with its mapping in `scenes/README.md`,
//! "Mitsuba 3 XML scenes"), read into the same raw form the TOML loader produces, and the
//! writer behind `brdfwave convert`.
//!
//! **One checking path.** The reader does not build a [`Scene`] itself: [`doc`] turns the
//! files into an owned element tree (includes spliced, `$name`s substituted), [`plugins`],
//! [`sensor`] and [`shapes`] map each element to the raw TOML form of
//! [`crate::scene::schema`] with every value spanned by its element, and the TOML loader's
//! [`crate::scene::assemble`] then checks and flattens it: camera, film and depth ranges,
//! materials (through the registry's `brdf::parse_material`, so `<bsdf type="ward">` takes the
//! model's own parameter names), degenerate triangles, OBJ files, transforms. A Mitsuba
//! `to_world` becomes the shape's TOML `matrix` transform. So every scene, whatever its
//! format, passes the same checks, and the XML side only adds the checks of XML itself (a
//! located message for each element or parameter it does not support: nothing is dropped).
//!
//! Messages name the file that holds the element (an included file is its own file) and its
//! line; the field is the element's path (`scene/shape[2]/bsdf[0]`) for the XML checks, and
//! the raw form's path (`shapes[2].sphere.radius`, shapes counted in file order) for the checks
//! of the assembly.

mod data;
mod doc;
mod plugins;
mod sensor;
mod shapes;
mod values;
pub mod write;

use super::error::SceneError;
use super::spanned::Cx;
use super::Scene;
use std::path::Path;

/// Load a Mitsuba 3 XML scene from its text; `defines` are the command line's `-D name=value`
/// (they override the file's `<default>`s).
pub(super) fn load_str(
    source: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<Scene, SceneError> {
    let files = doc::read(path, source, defines)?;
    // Relative file names are resolved against each element's own file's directory.
    let mut cx = Cx::new(crate::errors::shown_path(path), &files.source);
    cx.parts = files.parts.clone();
    cx.read_bytes = files.bytes_read;
    // A -D that the scene never substitutes is most likely misspelt.
    for name in &files.unused_defines {
        let msg = format!(
            "-D {}: the scene has no ${} to substitute it into",
            crate::errors::excerpt(name),
            crate::errors::excerpt(name)
        );
        cx.warn(None, "-D", msg);
    }
    let raw = plugins::scene(&mut cx, &files.elements)?;
    super::assemble::build(&mut cx, raw, path)
}
