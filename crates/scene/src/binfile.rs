//! Binary files: the one bounds-checked little-endian reader behind every
//! binary reader of vpctl (COLMAP models, label and confidence images, forest
//! models), and the frame of vpctl's own binary files.
//!
//! # vpctl's own binary files
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic, naming the kind of file |
//! | 4 | format version (u32) |
//! | ... | body, described by each format |
//! | 8 | FNV-1a 64 ([`fnv1a64`]) of every byte before it |
//!
//! [`checksummed`] writes this frame and [`ByteReader::open_checksummed`]
//! checks it, so truncation, bit rot and files of another kind or version
//! are caught before the body is parsed.

use std::path::Path;

use crate::error::{Location, Result, SceneError};

/// 64-bit FNV-1a hash: the checksum of vpctl's binary files. Any single
/// changed byte changes the hash (each step is a bijection of the state).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// A vpctl binary file: `magic`, `version`, the body `write_body` appends,
/// then the checksum of all of it.
pub fn checksummed(magic: [u8; 8], version: u32, write_body: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&magic);
    out.extend_from_slice(&version.to_le_bytes());
    write_body(&mut out);
    out.extend_from_slice(&fnv1a64(&out).to_le_bytes());
    out
}

/// A little-endian cursor over a file's bytes whose errors name the file,
/// the element being read (when set) and the byte offset.
#[derive(Debug)]
pub struct ByteReader<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
    /// Kind and index of the element being read, for error locations.
    element: Option<(&'static str, usize)>,
}

impl<'a> ByteReader<'a> {
    /// A reader at the start of `data`; `path` only names the file in errors.
    pub fn new(path: &'a Path, data: &'a [u8]) -> Self {
        ByteReader {
            path,
            data,
            pos: 0,
            element: None,
        }
    }

    /// Checks the frame of a vpctl binary file (magic, version, checksum;
    /// see the module docs) and returns a reader positioned at the start of
    /// the body that ends before the checksum. `what` names the kind of file
    /// in errors ("vp-forest model"), `made_by` the command that writes one
    /// ("`vpctl train`"), so that a wrong file says what was expected.
    pub fn open_checksummed(
        path: &'a Path,
        data: &'a [u8],
        magic: [u8; 8],
        version: u32,
        (what, made_by): (&str, &str),
    ) -> Result<Self> {
        let r = ByteReader::new(path, data);
        if data.is_empty() {
            return Err(r.error_at(
                0,
                format!("empty file: not a {what} (bad magic number); {made_by} writes one"),
            ));
        }
        if data.len() < 8 || data[..8] != magic {
            let seems = sniff(data).map_or(String::new(), |k| format!(": this is {k}"));
            return Err(r.error_at(
                0,
                format!(
                    "not a {what} (bad magic number){seems}; expected the file {made_by} writes"
                ),
            ));
        }
        if data.len() < 20 {
            return Err(r.error_at(
                data.len(),
                format!("truncated {what}: the file ends inside the header"),
            ));
        }
        let found = u32::from_le_bytes([data[8], data[9], data[10], data[11]]);
        if found != version {
            return Err(r.error_at(
                8,
                format!("{what} format version {found}; this build reads version {version}"),
            ));
        }
        let body = data.len() - 8;
        let mut stored = [0u8; 8];
        stored.copy_from_slice(&data[body..]);
        if u64::from_le_bytes(stored) != fnv1a64(&data[..body]) {
            return Err(r.error_at(
                body,
                "checksum mismatch: the file is truncated or corrupted",
            ));
        }
        Ok(ByteReader {
            data: &data[..body],
            pos: 12,
            ..r
        })
    }

    /// Byte offset of the next read.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes left to read.
    pub fn left(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Names the element being read in later errors (`None`: plain byte offsets).
    pub fn set_element(&mut self, element: Option<(&'static str, usize)>) {
        self.element = element;
    }

    /// `byte` as a location: in the current element if one is set.
    pub fn place(&self, byte: usize) -> Location {
        match self.element {
            Some((kind, index)) => Location::Element {
                kind: kind.to_string(),
                index,
                byte: Some(byte as u64),
            },
            None => Location::Byte(byte as u64),
        }
    }

    /// An error at `byte`, in the current element if one is set.
    pub fn error_at(&self, byte: usize, message: impl Into<String>) -> SceneError {
        SceneError::parse(self.path, self.place(byte), message)
    }

    /// The next `n` bytes; `what` names them if the file ends first.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.left() < n {
            return Err(self.error_at(
                self.pos,
                format!(
                    "file truncated: {what} needs {n} bytes, only {} left",
                    self.left()
                ),
            ));
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// The next `N` bytes as an array.
    pub fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N]> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, what)?);
        Ok(a)
    }

    /// One byte.
    pub fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.array::<1>(what)?[0])
    }

    /// A little-endian u32.
    pub fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    /// A little-endian i32.
    pub fn i32(&mut self, what: &str) -> Result<i32> {
        Ok(i32::from_le_bytes(self.array(what)?))
    }

    /// A little-endian u64.
    pub fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    /// A little-endian f32.
    pub fn f32(&mut self, what: &str) -> Result<f32> {
        Ok(f32::from_le_bytes(self.array(what)?))
    }

    /// A little-endian f64.
    pub fn f64(&mut self, what: &str) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array(what)?))
    }

    /// A little-endian f64 that must be finite.
    pub fn finite(&mut self, what: &str) -> Result<f64> {
        let at = self.pos;
        let v = self.f64(what)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.error_at(at, format!("{what} is {v}, expected a finite number")))
        }
    }

    /// A u64 count of items of at least `item_bytes` bytes each that must
    /// fit in the rest of the file: catches truncation early and never
    /// allocates for a corrupt count.
    pub fn count(&mut self, what: &str, item_bytes: usize) -> Result<usize> {
        let at = self.pos;
        let n = self.u64(what)?;
        self.fitting(at, n, what, item_bytes)
    }

    /// A u32 count, checked as [`ByteReader::count`].
    pub fn count_u32(&mut self, what: &str, item_bytes: usize) -> Result<usize> {
        let at = self.pos;
        let n = self.u32(what)?;
        self.fitting(at, u64::from(n), what, item_bytes)
    }

    fn fitting(&self, at: usize, n: u64, what: &str, item_bytes: usize) -> Result<usize> {
        let fits = usize::try_from(n)
            .ok()
            .filter(|&n| n.checked_mul(item_bytes).is_some_and(|b| b <= self.left()));
        fits.ok_or_else(|| {
            self.error_at(
                at,
                format!(
                    "file truncated or corrupt: {what} is {n}, but only {} bytes follow \
                     (at least {item_bytes} per item)",
                    self.left()
                ),
            )
        })
    }

    /// A NUL-terminated UTF-8 string.
    pub fn cstring(&mut self, what: &str) -> Result<String> {
        let at = self.pos;
        let rest = &self.data[self.pos..];
        let Some(len) = rest.iter().position(|&b| b == 0) else {
            return Err(self.error_at(at, format!("file truncated: {what} has no terminating NUL")));
        };
        let s = std::str::from_utf8(&rest[..len])
            .map_err(|_| self.error_at(at, format!("{what} is not UTF-8")))?
            .to_string();
        self.pos += len + 1;
        Ok(s)
    }

    /// Checks that nothing is left; `after` names what came last ("the last tree").
    pub fn finish(&mut self, after: &str) -> Result<()> {
        self.element = None;
        if self.left() > 0 {
            return Err(self.error_at(
                self.pos,
                format!("{} unexpected bytes after {after}", self.left()),
            ));
        }
        Ok(())
    }
}

/// What a file that is not the expected vpctl file looks like it is, from
/// its first bytes, for the error message.
fn sniff(data: &[u8]) -> Option<&'static str> {
    let starts = |m: &[u8]| data.starts_with(m);
    let text = std::str::from_utf8(&data[..data.len().min(64)]).ok();
    Some(if starts(b"\x89PNG") {
        "a PNG image"
    } else if starts(&[0xFF, 0xD8, 0xFF]) {
        "a JPEG image"
    } else if starts(b"II*\0") || starts(b"MM\0*") {
        "a TIFF image"
    } else if starts(b"ply") {
        "a PLY file"
    } else if starts(b"VPFOREST") || starts(b"VPFTREE") {
        "a vp-forest model (.vpforest)"
    } else if starts(b"VPCONF") {
        "a vpctl confidence image (.vpconf)"
    } else if starts(b"VPLABEL") {
        "a vpctl label image (.vplabel)"
    } else if text.is_some_and(|t| t.trim_start().starts_with('{')) {
        "a JSON file"
    } else if text.is_some() {
        "a text file"
    } else {
        return None;
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAGIC: [u8; 8] = *b"VPTEST\0\0";

    fn open(bytes: &[u8]) -> Result<ByteReader<'_>> {
        ByteReader::open_checksummed(Path::new("x.bin"), bytes, MAGIC, 3, ("test file", "`test`"))
    }

    #[test]
    fn frame_round_trips_and_rejects_damage() {
        let good = checksummed(MAGIC, 3, |out| out.extend_from_slice(&7u32.to_le_bytes()));
        let mut r = open(&good).unwrap();
        assert_eq!(r.u32("value").unwrap(), 7);
        r.finish("the value").unwrap();

        let msg = |b: &[u8]| open(b).unwrap_err().to_string();
        assert!(msg(&[]).contains("x.bin: byte 0: empty file"));
        assert!(msg(b"PNGPNGPNG").contains("bad magic number"));
        assert!(msg(&good[..15]).contains("truncated test file"));
        let mut v = good.clone();
        v[8] = 4;
        assert!(msg(&v).contains("test file format version 4; this build reads version 3"));
        let mut v = good.clone();
        v[13] ^= 1;
        assert!(msg(&v).contains("checksum mismatch"));
    }

    #[test]
    fn counts_that_cannot_fit_are_refused_before_allocating() {
        let mut bytes = u64::MAX.to_le_bytes().to_vec();
        bytes.extend_from_slice(&[0; 16]);
        let mut r = ByteReader::new(Path::new("x.bin"), &bytes);
        r.set_element(Some(("image", 4)));
        let e = r.count("point count", 24).unwrap_err().to_string();
        assert!(
            e.contains("x.bin: image 4 (byte 0): file truncated or corrupt"),
            "{e}"
        );
    }
}
