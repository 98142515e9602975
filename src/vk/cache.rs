//! On-disk caches (SPIR-V modules, the Vulkan pipeline cache): where they live, the stable hash
//! that keys them, and how cache files are written.

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

/// 64-bit FNV-1a (Fowler–Noll–Vo), written out so that cache keys stay stable across Rust
/// versions and platforms (`std::hash` makes no such promise).
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Fnv64 {
    const OFFSET_BASIS: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;

    pub fn new() -> Self {
        Fnv64(Self::OFFSET_BASIS)
    }

    pub fn bytes(&mut self, data: &[u8]) -> &mut Self {
        for &b in data {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(Self::PRIME);
        }
        self
    }

    /// A length-prefixed string, so that ("ab", "c") and ("a", "bc") hash differently.
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.bytes(&(s.len() as u64).to_le_bytes());
        self.bytes(s.as_bytes())
    }

    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

impl Default for Fnv64 {
    fn default() -> Self {
        Self::new()
    }
}

/// FNV-1a of one byte string.
pub fn fnv1a64(data: &[u8]) -> u64 {
    Fnv64::new().bytes(data).finish()
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
    fn fnv1a_known_values() {
        // Reference values of the FNV-1a 64-bit specification (draft-eastlake-fnv).
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn length_prefix_separates_fields() {
        let a = Fnv64::new().str("ab").str("c").finish();
        let b = Fnv64::new().str("a").str("bc").finish();
        assert_ne!(a, b);
    }

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
