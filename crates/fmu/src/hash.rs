//! The FMU's GUID: a fingerprint of what the binary checks at instantiation.
//!
//! FNV-1a (64 bit) run twice with different offset bases gives 128 bits, written like a UUID.
//! Not cryptographic — it only has to tell exports apart — but fully specified here, so that
//! the exporter (`airsus fmu`) and the library compute the same value whatever toolchain built
//! them (`std`'s hashers promise no stability across releases).

const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
/// A second basis (FNV-0 of "airsus-fmu"-like salt; any odd value that differs will do).
const SECOND_OFFSET: u64 = 0x6c62_272e_07bb_0142;

struct Fnv1a(u64);

impl Fnv1a {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(FNV_PRIME);
        }
    }
}

/// `{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}` from the parts, in order (each part is terminated,
/// so `["ab", "c"]` and `["a", "bc"]` differ).
pub(crate) fn guid(parts: &[&[u8]]) -> String {
    let mut a = Fnv1a(FNV_OFFSET);
    let mut b = Fnv1a(SECOND_OFFSET);
    for part in parts {
        a.write(part);
        a.write(&[0xff]);
        b.write(part);
        b.write(&[0xfe]);
    }
    let (x, y) = (a.0, b.0);
    format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        x >> 32,
        (x >> 16) & 0xffff,
        x & 0xffff,
        y >> 48,
        y & 0xffff_ffff_ffff
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_matches_the_published_test_vector() {
        // FNV-1a 64 of "a" is 0xaf63dc4c8601ec8c (reference implementation's test suite).
        let mut h = Fnv1a(FNV_OFFSET);
        h.write(b"a");
        assert_eq!(h.0, 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn guid_has_the_uuid_shape_and_separates_parts() {
        let g = guid(&[b"ab", b"c"]);
        assert_eq!(g.len(), 38, "{g}");
        assert!(g.starts_with('{') && g.ends_with('}'), "{g}");
        let groups: Vec<usize> = g[1..37].split('-').map(str::len).collect();
        assert_eq!(groups, [8, 4, 4, 4, 12]);
        assert_ne!(g, guid(&[b"a", b"bc"]));
        assert_eq!(g, guid(&[b"ab", b"c"]));
    }
}
