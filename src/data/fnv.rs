//! [`Fnv1a`]: the 64-bit FNV-1a hash that ties a `dataset.json` to its `dataset.npz`.

/// A 64-bit FNV-1a hash, fed in pieces. It identifies the `dataset.npz` that a `dataset.json`
/// was written with (not a defence against tampering, only against mixing up two runs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// Feeds `bytes`.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut h = self.0;
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self.0 = h;
    }

    /// The hash of everything fed so far.
    pub fn finish(&self) -> u64 {
        self.0
    }

    /// The hash of `bytes`.
    pub fn of(bytes: &[u8]) -> u64 {
        let mut h = Fnv1a::default();
        h.update(bytes);
        h.finish()
    }

    /// The length and hash of everything `r` yields.
    pub fn of_reader(mut r: impl std::io::Read) -> std::io::Result<(u64, u64)> {
        let mut h = Fnv1a::default();
        let mut buf = vec![0u8; 1 << 16];
        let mut len = 0u64;
        loop {
            let n = match r.read(&mut buf) {
                Ok(0) => return Ok((len, h.finish())),
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            h.update(&buf[..n]);
            len += n as u64;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_known_values() {
        // the reference values of the FNV-1a 64-bit test suite
        assert_eq!(Fnv1a::of(b""), 0xcbf29ce484222325);
        assert_eq!(Fnv1a::of(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(Fnv1a::of(b"foobar"), 0x85944171f73967e8);
        let mut h = Fnv1a::default();
        h.update(b"foo");
        h.update(b"bar");
        assert_eq!(h.finish(), 0x85944171f73967e8);
        let big: Vec<u8> = (0..200_000u32).map(|k| (k * 7 % 251) as u8).collect();
        assert_eq!(
            Fnv1a::of_reader(&big[..]).unwrap(),
            (200_000, Fnv1a::of(&big))
        );
    }
}
