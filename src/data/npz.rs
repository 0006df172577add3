//! A bounded reader of `.npz` archives of 1-D float64 arrays.
//!
//! `ndarray_npy::NpzReader` allocates whatever an array's header declares before it reads a
//! byte of data, so a damaged or hostile file (a shape of 10¹⁸ samples) aborts the process. This
//! reader checks every size first: an array's stored size against the memory budget
//! ([`super::memory_budget`]) and against the file it sits in, and its header's shape against
//! the bytes that follow it. Only then is anything allocated, and never more than the stored
//! size. The header is parsed by a small non-recursive parser of the one dictionary form numpy
//! writes (`{'descr': '<f8', 'fortran_order': False, 'shape': (64,), }`).

use std::io::{Read, Seek};

/// Largest ratio of uncompressed to compressed size that deflate can reach (≈ 1032:1); an
/// entry that claims more is damaged, and is refused before it is inflated.
const MAX_DEFLATE_RATIO: u64 = 1032;

/// One archive, open for reading arrays by name.
pub struct NpzArchive<R: Read + Seek> {
    zip: zip::ZipArchive<R>,
    /// The size of the whole archive in bytes (a bound on every stored entry).
    len: u64,
}

/// An `npz` held in memory.
pub type NpzBytes<'a> = NpzArchive<std::io::Cursor<&'a [u8]>>;

impl<'a> NpzBytes<'a> {
    /// Opens an archive held in memory.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, String> {
        NpzArchive::new(std::io::Cursor::new(bytes), bytes.len() as u64)
    }
}

impl NpzArchive<std::io::BufReader<std::fs::File>> {
    /// Opens the archive file `path`.
    pub fn open(path: &std::path::Path) -> Result<Self, String> {
        let f = super::infile::open(path).map_err(|e| e.to_string())?;
        let len = f.metadata().map_err(|e| e.to_string())?.len();
        NpzArchive::new(std::io::BufReader::new(f), len)
    }
}

impl<R: Read + Seek> NpzArchive<R> {
    /// Opens an archive of `len` bytes read from `reader`.
    pub fn new(reader: R, len: u64) -> Result<Self, String> {
        let zip = zip::ZipArchive::new(reader)
            .map_err(|e| format!("not a readable npz (zip) archive: {e}"))?;
        Ok(NpzArchive { zip, len })
    }

    /// The names of the arrays, in archive order (entry names without `.npy`).
    pub fn names(&self) -> Vec<String> {
        self.zip
            .file_names()
            .map(|n| n.strip_suffix(".npy").unwrap_or(n).to_string())
            .collect()
    }

    /// The index of array `name`'s entry.
    fn index(&self, name: &str) -> Option<usize> {
        let want = format!("{name}.npy");
        self.zip.index_for_name(&want)
    }

    /// The stored (uncompressed) size of array `name` in bytes, checked against the size of
    /// the archive: it cannot exceed it when stored, nor exceed it by more than deflate's
    /// largest ratio when compressed.
    pub fn stored_size(&mut self, name: &str) -> Result<u64, String> {
        let i = self
            .index(name)
            .ok_or_else(|| format!("no array `{name}`"))?;
        let len = self.len;
        let f = self
            .zip
            .by_index_raw(i)
            .map_err(|e| format!("array `{name}`: damaged archive entry: {e}"))?;
        let (size, packed) = (f.size(), f.compressed_size());
        if packed > len
            || size
                > packed
                    .saturating_mul(MAX_DEFLATE_RATIO)
                    .saturating_add(1024)
        {
            return Err(format!(
                "array `{name}`: the archive's directory claims {size} bytes ({packed} compressed) in a file of {len} bytes; the archive is damaged (rewrite it)"
            ));
        }
        Ok(size)
    }

    /// Reads array `name` as a 1-D float64 series (a 0-d array gives one sample). The stored
    /// size must fit in `budget` bytes. Errors name the array and say what is wrong with it.
    pub fn read_f64(&mut self, name: &str, budget: u64) -> Result<Vec<f64>, String> {
        let bytes = self.entry(
            name,
            budget,
            " (raise OCCAM_MEMORY_BUDGET, or shorten the series)",
        )?;
        parse_npy(&bytes).map_err(|m| format!("array `{name}`: {m}"))
    }

    /// Reads array `name` of any shape as one of the dtypes occam writes ([`NpyValues`]):
    /// `(shape, values in C order)`. The stored size must fit in `budget` bytes.
    pub fn read_array(&mut self, name: &str, budget: u64) -> Result<(Vec<u64>, NpyValues), String> {
        let bytes = self.entry(name, budget, " (raise OCCAM_MEMORY_BUDGET)")?;
        parse_npy_array(&bytes).map_err(|m| format!("array `{name}`: {m}"))
    }

    /// The stored bytes of array `name`, refused beyond `budget` (`fix` ends that message).
    fn entry(&mut self, name: &str, budget: u64, fix: &str) -> Result<Vec<u8>, String> {
        let size = self.stored_size(name)?;
        if size > budget {
            return Err(format!(
                "array `{name}` takes {size} bytes, more than the memory budget of {budget} bytes{fix}"
            ));
        }
        let i = self.index(name).expect("stored_size found it");
        let mut f = self
            .zip
            .by_index(i)
            .map_err(|e| format!("array `{name}`: cannot open the archive entry: {e}"))?;
        // `size` is checked above; `take` makes sure a lying entry cannot give more.
        let mut bytes = Vec::with_capacity(size as usize);
        (&mut f)
            .take(size)
            .read_to_end(&mut bytes)
            .map_err(|e| format!("array `{name}`: cannot read the archive entry: {e}"))?;
        // The archive checks an entry's CRC-32 only when it is read to its end, which `take`
        // stops just short of: one more read reaches it (numpy refuses a mismatch; so do we).
        let mut past = [0u8; 1];
        match f.read(&mut past) {
            Ok(0) => Ok(bytes),
            Ok(_) => Err(format!(
                "array `{name}`: the entry holds more than the {size} bytes its directory states; the archive is damaged (rewrite it)"
            )),
            Err(e) => Err(format!(
                "array `{name}`: {e} (the stored CRC-32 does not match the data: the file was damaged after it was written; rewrite it)"
            )),
        }
    }
}

/// The values of an array read by [`NpzArchive::read_array`].
#[derive(Debug, Clone, PartialEq)]
pub enum NpyValues {
    /// `<f8`.
    F64(Vec<f64>),
    /// `<i8`.
    I64(Vec<i64>),
    /// `|b1`.
    Bool(Vec<bool>),
    /// `<U{n}`, trailing NULs removed (numpy's reading of them).
    Str(Vec<String>),
}

/// The header and data of a `.npy` file: `(descr, shape, data)`.
fn split_npy(b: &[u8]) -> Result<(Header, &[u8]), String> {
    const MAGIC: &[u8] = b"\x93NUMPY";
    if b.len() < 10 || &b[..6] != MAGIC {
        return Err("not an .npy array (no `\\x93NUMPY` magic)".into());
    }
    let (hlen, start) = match b[6] {
        1 => (u16::from_le_bytes([b[8], b[9]]) as usize, 10usize),
        2 | 3 if b.len() >= 12 => (u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize, 12),
        v => return Err(format!("unsupported .npy format version {v}")),
    };
    let end = start
        .checked_add(hlen)
        .filter(|&e| e <= b.len())
        .ok_or_else(|| format!("truncated: the header declares {hlen} bytes"))?;
    let header =
        std::str::from_utf8(&b[start..end]).map_err(|_| "the header is not text".to_string())?;
    Ok((parse_header(header)?, &b[end..]))
}

/// Decodes a whole little-endian `.npy` file of float64, int64, bool or `<U` strings, any
/// shape (C order).
pub fn parse_npy_array(b: &[u8]) -> Result<(Vec<u64>, NpyValues), String> {
    let (h, data) = split_npy(b)?;
    let n = h
        .shape
        .iter()
        .try_fold(1u64, |a, &d| a.checked_mul(d))
        .ok_or("the shape's size overflows")?;
    let item: u64 = match h.descr.as_str() {
        "<f8" | "<i8" => 8,
        "|b1" => 1,
        d => match d.strip_prefix("<U").and_then(|w| w.parse::<u64>().ok()) {
            Some(w) if w > 0 => 4 * w,
            _ => return Err(format!("dtype `{d}` is not one of <f8, <i8, |b1, <U")),
        },
    };
    if n.checked_mul(item) != Some(data.len() as u64) {
        return Err(format!(
            "the header declares {n} values of {item} bytes but {} bytes of data follow",
            data.len()
        ));
    }
    let w8 = |c: &[u8]| -> [u8; 8] { c.try_into().expect("chunks of 8") };
    let v = match h.descr.as_str() {
        "<f8" => NpyValues::F64(
            data.chunks_exact(8)
                .map(|c| f64::from_le_bytes(w8(c)))
                .collect(),
        ),
        "<i8" => NpyValues::I64(
            data.chunks_exact(8)
                .map(|c| i64::from_le_bytes(w8(c)))
                .collect(),
        ),
        "|b1" => NpyValues::Bool(data.iter().map(|&x| x != 0).collect()),
        _ => NpyValues::Str(
            data.chunks_exact(item as usize)
                .map(|c| {
                    c.chunks_exact(4)
                        .map(|u| u32::from_le_bytes(u.try_into().expect("chunks of 4")))
                        .take_while(|&u| u != 0)
                        .map(|u| char::from_u32(u).ok_or(format!("{u:#x} is not a character")))
                        .collect::<Result<String, String>>()
                })
                .collect::<Result<_, _>>()?,
        ),
    };
    Ok((h.shape, v))
}

/// Decodes a whole `.npy` file holding a 1-D (or 0-d) float64 array.
pub fn parse_npy(b: &[u8]) -> Result<Vec<f64>, String> {
    const MAGIC: &[u8] = b"\x93NUMPY";
    if b.len() < 10 || &b[..6] != MAGIC {
        return Err("not an .npy array (no `\\x93NUMPY` magic)".into());
    }
    let (hlen, start) = match b[6] {
        1 => (u16::from_le_bytes([b[8], b[9]]) as usize, 10usize),
        2 | 3 if b.len() >= 12 => (u32::from_le_bytes([b[8], b[9], b[10], b[11]]) as usize, 12),
        v => return Err(format!("unsupported .npy format version {v}")),
    };
    let end = start
        .checked_add(hlen)
        .filter(|&e| e <= b.len())
        .ok_or_else(|| {
            format!(
                "truncated: the header declares {hlen} bytes but the array holds {}",
                b.len() - start.min(b.len())
            )
        })?;
    let header =
        std::str::from_utf8(&b[start..end]).map_err(|_| "the header is not text".to_string())?;
    let h = parse_header(header)?;
    let big = match h.descr.as_str() {
        "<f8" => false,
        ">f8" => true,
        d => {
            return Err(format!(
                "dtype `{d}`: occam reads float64 arrays (save with `.astype(numpy.float64)`)"
            ));
        }
    };
    let n = match h.shape.as_slice() {
        [] => 1,
        [n] => *n,
        s => {
            return Err(format!(
                "shape {s:?}: occam reads 1-D arrays (save the series with `.ravel()`)"
            ));
        }
    };
    let data = &b[end..];
    let want = n
        .checked_mul(8)
        .ok_or_else(|| format!("the header declares {n} samples, more than any file can hold"))?;
    if data.len() as u64 != want {
        return Err(format!(
            "the header declares {n} samples ({want} bytes) but {} bytes of data follow; the file is truncated or damaged",
            data.len()
        ));
    }
    Ok(data
        .chunks_exact(8)
        .map(|c| {
            let a: [u8; 8] = c.try_into().expect("chunks of 8");
            if big {
                f64::from_be_bytes(a)
            } else {
                f64::from_le_bytes(a)
            }
        })
        .collect())
}

/// The fields of an `.npy` header.
#[derive(Debug, PartialEq)]
struct Header {
    descr: String,
    shape: Vec<u64>,
}

/// Parses numpy's header dictionary: keys `descr` (a string), `fortran_order` (`True` or
/// `False`; irrelevant for 1-D data) and `shape` (a tuple of integers), in any order, with a
/// trailing comma allowed. Nothing else is accepted.
fn parse_header(h: &str) -> Result<Header, String> {
    let bad = |what: &str| format!("malformed header `{}`: {what}", clip(h));
    let mut s = Scanner {
        s: h.as_bytes(),
        i: 0,
    };
    s.expect(b'{').map_err(|_| bad("expected `{`"))?;
    let (mut descr, mut order, mut shape) = (None, None, None);
    loop {
        s.ws();
        if s.eat(b'}') {
            break;
        }
        let key = s.string().ok_or_else(|| bad("expected a quoted key"))?;
        s.ws();
        s.expect(b':').map_err(|_| bad("expected `:`"))?;
        s.ws();
        match key.as_str() {
            "descr" if descr.is_none() => {
                descr = Some(s.string().ok_or_else(|| bad("`descr` is not a string"))?)
            }
            "fortran_order" if order.is_none() => {
                order = Some(if s.word("True") {
                    true
                } else if s.word("False") {
                    false
                } else {
                    return Err(bad("`fortran_order` is not True or False"));
                })
            }
            "shape" if shape.is_none() => {
                shape = Some(
                    s.tuple()
                        .ok_or_else(|| bad("`shape` is not a tuple of integers"))?,
                )
            }
            k => return Err(bad(&format!("unexpected or repeated key `{k}`"))),
        }
        s.ws();
        if !s.eat(b',') {
            s.ws();
            s.expect(b'}').map_err(|_| bad("expected `,` or `}`"))?;
            break;
        }
    }
    if !s.rest().trim().is_empty() {
        return Err(bad("text after the dictionary"));
    }
    match (descr, order, shape) {
        (Some(descr), Some(_), Some(shape)) => Ok(Header { descr, shape }),
        _ => Err(bad("it needs `descr`, `fortran_order` and `shape`")),
    }
}

/// The first 80 characters of `h`, for messages.
fn clip(h: &str) -> String {
    let t: String = h.trim_end().chars().take(80).collect();
    if t.len() < h.trim_end().len() {
        format!("{t}…")
    } else {
        t
    }
}

struct Scanner<'a> {
    s: &'a [u8],
    i: usize,
}

impl Scanner<'_> {
    fn rest(&self) -> &str {
        std::str::from_utf8(&self.s[self.i..]).unwrap_or("?")
    }
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }
    fn eat(&mut self, c: u8) -> bool {
        if self.s.get(self.i) == Some(&c) {
            self.i += 1;
            true
        } else {
            false
        }
    }
    fn expect(&mut self, c: u8) -> Result<(), ()> {
        if self.eat(c) { Ok(()) } else { Err(()) }
    }
    fn word(&mut self, w: &str) -> bool {
        if self.s[self.i..].starts_with(w.as_bytes()) {
            self.i += w.len();
            true
        } else {
            false
        }
    }
    /// A string in single or double quotes, without escapes.
    fn string(&mut self) -> Option<String> {
        let q = *self.s.get(self.i)?;
        if q != b'\'' && q != b'"' {
            return None;
        }
        let len = self.s[self.i + 1..].iter().position(|&c| c == q)?;
        let v = std::str::from_utf8(&self.s[self.i + 1..self.i + 1 + len]).ok()?;
        self.i += len + 2;
        Some(v.to_string())
    }
    fn int(&mut self) -> Option<u64> {
        let start = self.i;
        while self.i < self.s.len() && self.s[self.i].is_ascii_digit() {
            self.i += 1;
        }
        // a trailing `L` is how Python 2 wrote long integers
        let v = std::str::from_utf8(&self.s[start..self.i])
            .ok()?
            .parse()
            .ok()?;
        self.eat(b'L');
        Some(v)
    }
    /// `()`, `(n,)` or `(n, m, …)`, with an optional trailing comma.
    fn tuple(&mut self) -> Option<Vec<u64>> {
        if !self.eat(b'(') {
            return None;
        }
        let mut v = Vec::new();
        loop {
            self.ws();
            if self.eat(b')') {
                return Some(v);
            }
            // a header is at most 4 GiB, so this cannot grow without bound; 32 axes is numpy's limit
            if v.len() >= 64 {
                return None;
            }
            v.push(self.int()?);
            self.ws();
            if !self.eat(b',') {
                self.ws();
                return self.eat(b')').then_some(v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array1;
    use ndarray_npy::{NpzWriter, WriteNpyExt};

    fn npy(v: &[f64]) -> Vec<u8> {
        let mut out = Vec::new();
        Array1::from_vec(v.to_vec()).write_npy(&mut out).unwrap();
        out
    }

    /// An `.npy` file with header text `h` (padded as numpy does) and `data`.
    fn raw(h: &str, data: &[u8]) -> Vec<u8> {
        let mut h = h.to_string();
        while !(10 + h.len() + 1).is_multiple_of(64) {
            h.push(' ');
        }
        h.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend((h.len() as u16).to_le_bytes());
        out.extend(h.as_bytes());
        out.extend(data);
        out
    }

    #[test]
    fn reads_what_ndarray_npy_writes() {
        let v = [1.5, -2.0, 1e-300, f64::MAX];
        assert_eq!(parse_npy(&npy(&v)).unwrap(), v);
        assert_eq!(parse_npy(&npy(&[])).unwrap(), Vec::<f64>::new());
        let mut z = NpzWriter::new(std::io::Cursor::new(Vec::new()));
        z.add_array("a.o1", &Array1::from_vec(v.to_vec())).unwrap();
        z.add_array("b", &Array1::from_vec(vec![3.0])).unwrap();
        let bytes = z.finish().unwrap().into_inner();
        let mut a = NpzBytes::from_bytes(&bytes).unwrap();
        assert_eq!(a.names(), vec!["a.o1", "b"]);
        assert_eq!(a.read_f64("a.o1", 1 << 20).unwrap(), v);
        assert_eq!(a.read_f64("b", 1 << 20).unwrap(), vec![3.0]);
        let e = a.read_f64("c", 1 << 20).unwrap_err();
        assert!(e.contains("no array `c`"), "{e}");
        // the budget is checked against the stored size before reading
        let e = a.read_f64("a.o1", 100).unwrap_err();
        assert!(
            e.contains("a.o1") && e.contains("memory budget of 100"),
            "{e}"
        );
    }

    #[test]
    fn big_endian_scalar_and_header_variants() {
        let x = 0.1f64;
        let b = raw(
            "{\"shape\": (), 'fortran_order': True, 'descr': '>f8'}",
            &x.to_be_bytes(),
        );
        assert_eq!(parse_npy(&b).unwrap(), vec![0.1]);
        let b = raw(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2L,), }",
            &[1f64.to_le_bytes(), 2f64.to_le_bytes()].concat(),
        );
        assert_eq!(parse_npy(&b).unwrap(), vec![1.0, 2.0]);
    }

    #[test]
    fn sizes_are_checked_before_allocating() {
        // a shape of 10^18 samples with 8 bytes of data: refused, nothing allocated
        let b = raw(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000000000,), }",
            &[0; 8],
        );
        let e = parse_npy(&b).unwrap_err();
        assert!(
            e.contains("1000000000000000000 samples") && e.contains("8 bytes"),
            "{e}"
        );
        let b = raw(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (18446744073709551615,), }",
            &[],
        );
        assert!(parse_npy(&b).unwrap_err().contains("more than any file"));
        // one byte too many or too few
        let mut b = npy(&[1.0, 2.0]);
        b.push(0);
        assert!(parse_npy(&b).unwrap_err().contains("17 bytes of data"));
        b.truncate(b.len() - 2);
        assert!(parse_npy(&b).unwrap_err().contains("15 bytes of data"));
    }

    #[test]
    fn wrong_types_and_headers_are_named() {
        let cases = [
            (
                "{'descr': '<f4', 'fortran_order': False, 'shape': (1,), }",
                "dtype `<f4`",
            ),
            (
                "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 2), }",
                "1-D",
            ),
            ("{'descr': '<f8', 'fortran_order': False}", "needs `descr`"),
            (
                "{'descr': '<f8', 'descr': '<f8', 'fortran_order': False, 'shape': (1,)}",
                "repeated key `descr`",
            ),
            (
                "{'descr': '<f8', 'fortran_order': 0, 'shape': (1,)}",
                "True or False",
            ),
            (
                "{'descr': '<f8', 'fortran_order': False, 'shape': [1]}",
                "tuple",
            ),
            (
                "{'descr': '<f8', 'fortran_order': False, 'shape': (1,)} x",
                "after the dictionary",
            ),
            ("['descr']", "expected `{`"),
            (
                "{'descr': '<f8' 'fortran_order': False}",
                "expected `,` or `}`",
            ),
            ("{'descr: '<f8'", "expected `:`"),
        ];
        for (h, want) in cases {
            let e = parse_npy(&raw(h, &[0; 8])).unwrap_err();
            assert!(e.contains(want), "{h}: {e}");
        }
        assert!(
            parse_npy(b"\x93NUMPY\x01\x00\xff\xff{")
                .unwrap_err()
                .contains("truncated")
        );
        assert!(parse_npy(b"PK\x03\x04").unwrap_err().contains("magic"));
        assert!(
            parse_npy(b"\x93NUMPY\x07\x00\x00\x00")
                .unwrap_err()
                .contains("version 7")
        );
        let deep = format!(
            "{{'descr': '<f8', 'fortran_order': False, 'shape': ({}), }}",
            "1,".repeat(100)
        );
        assert!(parse_npy(&raw(&deep, &[])).unwrap_err().contains("tuple"));
    }

    #[test]
    fn a_crc_mismatch_is_refused() {
        use std::io::Write;
        let values: Vec<f64> = (0..64).map(|i| i as f64).collect();
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let stored = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored);
        zip.start_file("x.npy", stored).unwrap();
        zip.write_all(&npy(&values)).unwrap();
        let good = zip.finish().unwrap().into_inner();
        assert_eq!(
            NpzBytes::from_bytes(&good)
                .unwrap()
                .read_f64("x", 1 << 20)
                .unwrap(),
            values
        );
        // flip one mantissa bit of the last sample: the array still parses, the CRC does not match
        let at = good
            .windows(8)
            .rposition(|w| w == 63f64.to_le_bytes())
            .unwrap();
        let mut bad = good.clone();
        bad[at] ^= 1;
        let e = NpzBytes::from_bytes(&bad)
            .unwrap()
            .read_f64("x", 1 << 20)
            .unwrap_err();
        assert!(e.contains("array `x`") && e.contains("CRC-32"), "{e}");
    }

    #[test]
    fn damaged_archives_are_errors() {
        assert!(NpzBytes::from_bytes(b"").is_err());
        let e = NpzBytes::from_bytes(b"not a zip at all").err().unwrap();
        assert!(e.contains("zip"), "{e}");
    }
}
