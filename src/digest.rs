//! SHA-256 digests as lower-case hex: the content hashes that key the table cache, the sweep and
//! report reuse checks, and the file lists of LUT and sweep folders.

use sha2::{Digest, Sha256};

/// SHA-256 of `bytes`, as 64 lower-case hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// SHA-256 of `values` as little-endian f64, one after another (the bytes of a table's `.f64`
/// values block).
pub fn values_sha256(values: &[f64]) -> String {
    let mut h = Sha256::new();
    for v in values {
        h.update(v.to_le_bytes());
    }
    hex(&h.finalize())
}

fn hex(digest: &[u8]) -> String {
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_digests() {
        // FIPS 180-2, appendix B.1
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        let v = [1.0, -0.5];
        let bytes: Vec<u8> = v.iter().flat_map(|x: &f64| x.to_le_bytes()).collect();
        assert_eq!(values_sha256(&v), sha256_hex(&bytes));
    }
}
