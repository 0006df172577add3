//! The messages between the ranks of an MPI job (the `mpi` module), as bytes: encoded and
//! decoded here, apart from MPI, so that the format is tested in every build (the `mpi`
//! feature's own build and test then need no second compile of the library).
//!
//! Wire format (little-endian u64 words): a request is `0, capacity, n, (index, len, bytes)*n`
//! or `1` followed by the UTF-8 error; a batch is `n, index*n`; an outcome is `0` or `1` + error.

use anyhow::{Context, Result, anyhow, bail};

/// A worker rank's request: the results of its last batch and its capacity, or its error.
#[derive(Debug, PartialEq)]
pub(super) enum Request {
    Done {
        capacity: usize,
        results: Vec<(usize, Vec<u8>)>,
    },
    Failed(String),
}

fn put(buf: &mut Vec<u8>, x: usize) {
    buf.extend_from_slice(&(x as u64).to_le_bytes());
}

/// Reads the words of a message in order, failing (not panicking) on a short message.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn word(&mut self) -> Result<usize> {
        let (w, rest) = self
            .0
            .split_first_chunk::<8>()
            .ok_or_else(|| anyhow!("message ends early"))?;
        self.0 = rest;
        usize::try_from(u64::from_le_bytes(*w)).context("word does not fit in usize")
    }

    fn bytes(&mut self, n: usize) -> Result<&[u8]> {
        if self.0.len() < n {
            bail!(
                "message ends early: {n} bytes announced, {} left",
                self.0.len()
            );
        }
        let (b, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(b)
    }

    fn end(&self) -> Result<()> {
        if !self.0.is_empty() {
            bail!("{} stray bytes at the end of the message", self.0.len());
        }
        Ok(())
    }
}

pub(super) fn encode_done(capacity: usize, results: &[(usize, Vec<u8>)]) -> Vec<u8> {
    let mut buf = Vec::new();
    put(&mut buf, 0);
    put(&mut buf, capacity);
    put(&mut buf, results.len());
    for (i, b) in results {
        put(&mut buf, *i);
        put(&mut buf, b.len());
        buf.extend_from_slice(b);
    }
    buf
}

pub(super) fn encode_failed(msg: &str) -> Vec<u8> {
    let mut buf = Vec::new();
    put(&mut buf, 1);
    buf.extend_from_slice(msg.as_bytes());
    buf
}

pub(super) fn decode_request(bytes: &[u8]) -> Result<Request> {
    let mut r = Reader(bytes);
    match r.word()? {
        0 => {
            let capacity = r.word()?;
            let n = r.word()?;
            let mut results = Vec::with_capacity(n.min(bytes.len() / 16));
            for _ in 0..n {
                let i = r.word()?;
                let len = r.word()?;
                results.push((i, r.bytes(len)?.to_vec()));
            }
            r.end()?;
            Ok(Request::Done { capacity, results })
        }
        1 => Ok(Request::Failed(String::from_utf8_lossy(r.0).into_owned())),
        s => bail!("unknown request status {s}"),
    }
}

pub(super) fn encode_indices(batch: &[usize]) -> Vec<u8> {
    let mut buf = Vec::with_capacity(8 * (batch.len() + 1));
    put(&mut buf, batch.len());
    for &i in batch {
        put(&mut buf, i);
    }
    buf
}

pub(super) fn decode_indices(bytes: &[u8]) -> Result<Vec<usize>> {
    let mut r = Reader(bytes);
    let n = r.word()?;
    if n > r.0.len() / 8 {
        bail!(
            "message ends early: {n} indices announced, {} bytes left",
            r.0.len()
        );
    }
    let out = (0..n).map(|_| r.word()).collect::<Result<Vec<_>>>()?;
    r.end()?;
    Ok(out)
}

pub(super) fn encode_outcome(failure: Option<&str>) -> Vec<u8> {
    match failure {
        None => encode_indices(&[]),
        Some(e) => encode_failed(e),
    }
}

pub(super) fn decode_outcome(bytes: &[u8]) -> Result<Option<String>> {
    let mut r = Reader(bytes);
    match r.word()? {
        0 => {
            r.end()?;
            Ok(None)
        }
        1 => Ok(Some(String::from_utf8_lossy(r.0).into_owned())),
        s => bail!("unknown outcome status {s}"),
    }
}

#[cfg(test)]
mod tests {
    //! The wire format, without MPI (the ranks themselves are exercised by
    //! `examples/mpi_exec.rs` under `mpirun -n 2`, in CI).
    use super::*;

    #[test]
    fn requests_round_trip_including_empty_and_binary_results() {
        let results = vec![
            (3, b"{\"x\":1}".to_vec()),
            (0, Vec::new()),
            (usize::MAX >> 1, vec![0, 255, 1, 0]),
        ];
        let got = decode_request(&encode_done(4, &results)).unwrap();
        assert_eq!(
            got,
            Request::Done {
                capacity: 4,
                results
            }
        );
        let empty = decode_request(&encode_done(1, &[])).unwrap();
        assert_eq!(
            empty,
            Request::Done {
                capacity: 1,
                results: vec![]
            }
        );
        let failed = decode_request(&encode_failed("task 7: disk full")).unwrap();
        assert_eq!(failed, Request::Failed("task 7: disk full".into()));
    }

    #[test]
    fn batches_and_outcomes_round_trip() {
        for b in [vec![], vec![5], vec![9, 1, 4]] {
            assert_eq!(decode_indices(&encode_indices(&b)).unwrap(), b);
        }
        assert_eq!(decode_outcome(&encode_outcome(None)).unwrap(), None);
        assert_eq!(
            decode_outcome(&encode_outcome(Some("rank 1: task 2 failed"))).unwrap(),
            Some("rank 1: task 2 failed".into())
        );
    }

    #[test]
    fn truncated_or_padded_messages_are_errors_not_panics() {
        let good = encode_done(2, &[(1, b"abc".to_vec())]);
        for cut in 0..good.len() {
            assert!(decode_request(&good[..cut]).is_err(), "cut at {cut}");
        }
        let mut long = good.clone();
        long.push(0);
        let e = decode_request(&long).unwrap_err();
        assert!(e.to_string().contains("stray"), "{e}");
        let e = decode_request(&encode_indices(&[7, 8])).unwrap_err(); // first word 2
        assert!(e.to_string().contains("status"), "{e}");
        assert!(decode_indices(&encode_indices(&[1, 2])[..12]).is_err());
        // A length word far beyond the message must not allocate or read past the end.
        let mut huge = Vec::new();
        for w in [0usize, 1, 1, 0, usize::MAX >> 8] {
            put(&mut huge, w);
        }
        assert!(decode_request(&huge).is_err());
    }
}
