//! The stable hash of the program: 64-bit FNV-1a, for keys that are written to disk and compared
//! across runs and machines (shader and pipeline caches, the scene hash of partial films).

/// 64-bit FNV-1a (Fowler–Noll–Vo), written out so that keys stay stable across Rust versions
/// and platforms (`std::hash` makes no such promise).
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

/// FNV-1a of RGB texels' bits: how an image enters a scene's `{:?}` (the hash of partial
/// films), as one number instead of millions.
pub fn texels_hash(texels: &[[f32; 3]]) -> u64 {
    let mut h = Fnv64::new();
    for c in texels.iter().flatten() {
        h.bytes(&c.to_bits().to_le_bytes());
    }
    h.finish()
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

/// Text written with `write!` is hashed as its bytes (no length prefix).
impl std::fmt::Write for Fnv64 {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
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
}
