//! Why a scene could not be loaded: the one error type of every step of loading, which names the
//! file, the line and the field.

use crate::brdf::ParamError;

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
