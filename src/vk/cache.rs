//! On-disk caches (SPIR-V modules, the Vulkan pipeline cache): where they live and how cache
//! files are written; they are keyed by [`crate::hash::Fnv64`].

use anyhow::{Context as _, Result};
use std::path::{Path, PathBuf};

/// The cache root: `$BRDFWAVE_CACHE_DIR`, else `$XDG_CACHE_HOME/brdfwave`, else
/// `$HOME/.cache/brdfwave`; `None` when none of these variables is set (caching is then off).
pub fn default_cache_dir() -> Option<PathBuf> {
    let var = |name: &str| {
        std::env::var_os(name)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    if let Some(dir) = var("BRDFWAVE_CACHE_DIR") {
        return Some(dir);
    }
    if let Some(dir) = var("XDG_CACHE_HOME") {
        return Some(dir.join("brdfwave"));
    }
    var("HOME").map(|home| home.join(".cache").join("brdfwave"))
}

/// Writes a cache file with the crate's one atomic writer ([`crate::outfile::write`]: temporary
/// file, then rename, so readers such as parallel tests never see a partial entry), creating the
/// cache directory first.
pub fn write_atomic(path: &Path, data: &[u8]) -> Result<()> {
    let dir = crate::outfile::parent_dir(path);
    std::fs::create_dir_all(dir)
        .with_context(|| format!("creating cache directory {}", dir.display()))?;
    crate::outfile::write(path, data)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub").join("x.bin");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        // No temporary files are left behind.
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 1);
    }
}
