//! A writer of `.npz` archives that `numpy.load` reads without `allow_pickle`: float64, int64,
//! bool and fixed-width unicode (`<U{n}`) arrays of any shape.
//!
//! `ndarray-npy` writes numbers but no strings, and the sample files need parameter and model
//! names beside the numbers, so the few lines of the format are written here. Each array is an
//! uncompressed `.npy` (format 1.0) entry, byte for byte what `numpy.save` writes for it
//! (header padding included, see [`npy_header`]); the zip entries carry a fixed timestamp so the
//! same arrays always give the same file.

use std::io::{Seek, Write};

/// The values of one array, flattened in C (row-major) order.
#[derive(Debug, Clone, PartialEq)]
pub enum NpyData {
    /// `<f8`.
    F64(Vec<f64>),
    /// `<i8`.
    I64(Vec<i64>),
    /// `|b1`.
    Bool(Vec<bool>),
    /// `<U{n}` with `n` the longest string in characters (at least 1): UCS-4 little endian,
    /// zero-padded.
    Str(Vec<String>),
}

impl NpyData {
    fn len(&self) -> usize {
        match self {
            NpyData::F64(v) => v.len(),
            NpyData::I64(v) => v.len(),
            NpyData::Bool(v) => v.len(),
            NpyData::Str(v) => v.len(),
        }
    }

    /// Characters of the widest string (numpy's `<U` width; 1 for none, as numpy gives).
    fn str_width(v: &[String]) -> usize {
        v.iter()
            .map(|s| s.chars().count())
            .max()
            .unwrap_or(0)
            .max(1)
    }

    fn descr(&self) -> String {
        match self {
            NpyData::F64(_) => "<f8".into(),
            NpyData::I64(_) => "<i8".into(),
            NpyData::Bool(_) => "|b1".into(),
            NpyData::Str(v) => format!("<U{}", Self::str_width(v)),
        }
    }

    fn write_values(&self, w: &mut impl Write) -> std::io::Result<()> {
        match self {
            NpyData::F64(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            NpyData::I64(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            NpyData::Bool(v) => v.iter().try_for_each(|&x| w.write_all(&[x as u8])),
            NpyData::Str(v) => {
                let width = Self::str_width(v);
                for s in v {
                    let mut n = 0;
                    for c in s.chars() {
                        w.write_all(&(c as u32).to_le_bytes())?;
                        n += 1;
                    }
                    for _ in n..width {
                        w.write_all(&[0; 4])?;
                    }
                }
                Ok(())
            }
        }
    }

    fn value_bytes(&self) -> u64 {
        let n = self.len() as u64;
        match self {
            NpyData::F64(_) | NpyData::I64(_) => 8 * n,
            NpyData::Bool(_) => n,
            NpyData::Str(v) => 4 * Self::str_width(v) as u64 * n,
        }
    }
}

/// numpy's spelling of a shape: `()`, `(2,)`, `(2, 3)`.
fn shape_repr(shape: &[usize]) -> String {
    match shape {
        [] => "()".into(),
        [n] => format!("({n},)"),
        s => format!(
            "({})",
            s.iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The `.npy` 1.0 preamble (magic, version, header length, header) exactly as `numpy.save`
/// writes it: the dictionary, 21 minus the digits of the first axis' length in spaces (room
/// for numpy to grow the array in place), then spaces to a multiple of 64 bytes and `\n`.
pub fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let mut h = format!(
        "{{'descr': '{descr}', 'fortran_order': False, 'shape': {}, }}",
        shape_repr(shape)
    );
    if let Some(first) = shape.first() {
        h.push_str(&" ".repeat(21usize.saturating_sub(first.to_string().len())));
    }
    let hlen = h.len() + 1;
    let pad = 64 - (10 + hlen) % 64;
    h.push_str(&" ".repeat(pad));
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    // a header over 64 KiB would need format 2.0; shapes of ≤ 32 axes never get there
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out
}

/// One array to store: name (the entry is `<name>.npy`), shape, values.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyArray {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: NpyData,
}

impl NpyArray {
    /// An array of `shape`; panics if the values do not fill it (a programming error).
    pub fn new(name: &str, shape: &[usize], data: NpyData) -> Self {
        assert_eq!(
            shape.iter().product::<usize>(),
            data.len(),
            "array `{name}`: shape {shape:?} does not match {} values",
            data.len()
        );
        Self {
            name: name.into(),
            shape: shape.to_vec(),
            data,
        }
    }
}

/// Writes `arrays` as an npz archive to `w` (uncompressed, like `numpy.savez`).
pub fn write_npz<W: Write + Seek>(w: W, arrays: &[NpyArray]) -> std::io::Result<()> {
    let mut z = zip::ZipWriter::new(w);
    for a in arrays {
        let header = npy_header(&a.data.descr(), &a.shape);
        let size = header.len() as u64 + a.data.value_bytes();
        let opts = zip::write::SimpleFileOptions::default()
            .compression_method(zip::CompressionMethod::Stored)
            .last_modified_time(zip::DateTime::default())
            .large_file(size >= u32::MAX as u64);
        z.start_file(format!("{}.npy", a.name), opts)
            .map_err(std::io::Error::other)?;
        z.write_all(&header)?;
        let mut b = std::io::BufWriter::new(&mut z);
        a.data.write_values(&mut b)?;
        b.flush()?;
    }
    z.finish().map_err(std::io::Error::other)?;
    Ok(())
}

/// Writes `arrays` to `path` atomically ([`crate::atomic::write_with`]).
pub fn write_npz_file(path: &std::path::Path, arrays: &[NpyArray]) -> std::io::Result<()> {
    crate::atomic::write_with(path, |w| write_npz(w, arrays))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::npz::{NpyValues, NpzBytes};

    #[test]
    fn headers_are_byte_for_byte_numpys() {
        // printed by numpy 2.4: `np.save(b, np.array(['ab', 'cde'], dtype='<U5'))`
        let mut want = b"\x93NUMPY\x01\x00v\x00".to_vec();
        want.extend_from_slice(
            format!(
                "{{'descr': '<U5', 'fortran_order': False, 'shape': (2,), }}{}\n",
                " ".repeat(60)
            )
            .as_bytes(),
        );
        assert_eq!(npy_header("<U5", &[2]), want);
        // 0-d: no growth padding; 3-d: growth padding for the first axis only
        for (d, s, spaces) in [
            ("<i8", vec![], 62usize),
            ("<f8", vec![2, 3, 4], 55),
            ("<f8", vec![0, 5], 58),
        ] {
            let h = npy_header(d, &s);
            assert_eq!(h.len(), 128, "{d} {s:?}");
            let text = std::str::from_utf8(&h[10..]).unwrap();
            assert_eq!(
                text.len() - text.trim_end_matches([' ', '\n']).len(),
                spaces + 1
            );
        }
        // numpy 2.4 for `np.zeros((1, 999999))`: 118 header bytes
        assert_eq!(npy_header("<f8", &[1, 999_999]).len(), 128);
        for s in [vec![usize::MAX], vec![9; 32], vec![1, 2, 3, 4, 5, 6]] {
            let h = npy_header("<U64", &s);
            assert_eq!((h.len() % 64, h.last()), (0, Some(&b'\n')), "{s:?}");
        }
    }

    #[test]
    fn every_dtype_reads_back() {
        let arrays = [
            NpyArray::new(
                "f",
                &[2, 1, 2],
                NpyData::F64(vec![1.0, f64::NAN, -0.0, 3.5]),
            ),
            NpyArray::new("i", &[3], NpyData::I64(vec![-1, 0, i64::MAX])),
            NpyArray::new("b", &[2, 2], NpyData::Bool(vec![true, false, false, true])),
            NpyArray::new(
                "s",
                &[3],
                NpyData::Str(vec!["x_1".into(), "".into(), "μ₀".into()]),
            ),
            NpyArray::new("e", &[0], NpyData::Str(vec![])),
            NpyArray::new("z", &[0, 4], NpyData::F64(vec![])),
            NpyArray::new("scalar", &[], NpyData::I64(vec![7])),
        ];
        let mut buf = std::io::Cursor::new(Vec::new());
        write_npz(&mut buf, &arrays).unwrap();
        let bytes = buf.into_inner();
        let mut z = NpzBytes::from_bytes(&bytes).unwrap();
        assert_eq!(z.names(), ["f", "i", "b", "s", "e", "z", "scalar"]);
        for a in &arrays {
            let (shape, v) = z.read_array(&a.name, u64::MAX).unwrap();
            assert_eq!(shape, a.shape.iter().map(|&n| n as u64).collect::<Vec<_>>());
            match (&a.data, v) {
                (NpyData::F64(w), NpyValues::F64(g)) => {
                    assert_eq!(
                        w.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        g.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
                    )
                }
                (NpyData::I64(w), NpyValues::I64(g)) => assert_eq!(w, &g),
                (NpyData::Bool(w), NpyValues::Bool(g)) => assert_eq!(w, &g),
                (NpyData::Str(w), NpyValues::Str(g)) => assert_eq!(w, &g),
                (w, g) => panic!("{}: wrote {w:?}, read {g:?}", a.name),
            }
        }
        // same arrays, same bytes (fixed timestamps)
        let mut again = std::io::Cursor::new(Vec::new());
        write_npz(&mut again, &arrays).unwrap();
        assert_eq!(again.into_inner(), bytes);
    }

    #[test]
    #[should_panic(expected = "does not match")]
    fn a_shape_that_does_not_fit_the_values_is_a_bug() {
        NpyArray::new("x", &[2, 2], NpyData::F64(vec![1.0]));
    }
}
