//! The hash contract: a frame's hash is the SHA-256 of its raw 8-bit RGB pixels, row-major,
//! top row first, 3 bytes a pixel, no header. Anyone can recompute it from the PNG with any
//! image library.

use sha2::{Digest, Sha256};

/// A frame's hash: the SHA-256 of its raw RGB8 pixels. It is written, read and shown as 64
/// lower-case hex digits (any case is read).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameHash(pub [u8; 32]);

impl FrameHash {
    /// The hash of raw RGB8 pixels.
    pub fn of(pixels: &[u8]) -> FrameHash {
        FrameHash(Sha256::digest(pixels).into())
    }
}

impl std::fmt::Display for FrameHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

impl std::fmt::Debug for FrameHash {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "FrameHash({self})")
    }
}

impl std::str::FromStr for FrameHash {
    type Err = String;

    /// 64 hex digits.
    fn from_str(s: &str) -> std::result::Result<FrameHash, String> {
        // Only digits: `from_str_radix` alone would take a sign (`+f`).
        if s.len() != 64 || !s.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(format!("{s:?} is not a SHA-256 (64 hex digits)"));
        }
        let byte = |i: usize| u8::from_str_radix(&s[2 * i..2 * i + 2], 16).expect("hex digits");
        Ok(FrameHash(std::array::from_fn(byte)))
    }
}

impl PartialEq<str> for FrameHash {
    fn eq(&self, other: &str) -> bool {
        other.parse::<FrameHash>().is_ok_and(|h| h == *self)
    }
}

impl PartialEq<&str> for FrameHash {
    fn eq(&self, other: &&str) -> bool {
        *self == **other
    }
}

impl PartialEq<String> for FrameHash {
    fn eq(&self, other: &String) -> bool {
        *self == *other.as_str()
    }
}

/// The hash of raw RGB8 pixels ([`FrameHash::of`]).
pub fn frame_hash(pixels: &[u8]) -> FrameHash {
    FrameHash::of(pixels)
}

/// [`frame_hash`] fed a frame's bytes a piece at a time, in order (a row at a time as the
/// rows are rendered).
#[derive(Default)]
pub struct FrameHasher(Sha256);

impl FrameHasher {
    /// Adds the next bytes of the frame.
    pub fn update(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    /// The hash of everything added.
    pub fn finish(self) -> FrameHash {
        FrameHash(self.0.finalize().into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_of_known_bytes() {
        // SHA-256("abc") from FIPS 180-2, appendix B.1.
        assert_eq!(
            frame_hash(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn a_hash_reads_and_writes_as_64_hex_digits() {
        let hex = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
        let h: FrameHash = hex.to_ascii_uppercase().parse().unwrap();
        assert_eq!(h, frame_hash(b"abc"));
        assert_eq!(h.to_string(), hex);
        assert_eq!(h.0[0], 0xba);
        let signed = format!("+{}", &hex[1..]);
        for bad in [
            "",
            &hex[1..],
            &format!("{hex}0"),
            &hex.replace('b', "g"),
            &signed,
        ] {
            assert!(bad.parse::<FrameHash>().is_err(), "{bad}");
        }
    }
}
