//! Image files named by a scene (an environment map, a texture): read through
//! [`crate::imageio::read_stored`], every failure turned into a scene error that names the
//! field and the file (missing, unreadable, truncated, not an image, an unknown format, an
//! empty image or one over the size limit).

use super::error::SceneError;
use super::spanned::Cx;
use crate::imageio::{read_stored, Stored};
use std::ops::Range;
use std::path::Path;

/// The image at `path`, named by field `field` (at `span`).
pub(super) fn read(
    cx: &Cx,
    span: Option<Range<usize>>,
    field: &str,
    path: &Path,
) -> Result<Stored, SceneError> {
    read_stored(path).map_err(|e| {
        // The image errors start with the path already.
        let msg = format!("cannot read the image: {e}");
        cx.err(span, field, msg)
    })
}
