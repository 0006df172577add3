//! One checkpoint format for every job (`fit`'s chains, `select`'s stages, `sweep`'s tasks):
//! CBOR, which keeps every f64 bit (NaN and ±∞ included, which JSON cannot hold), inside an
//! envelope that names the format, the kind of run, its version and the identity of the run it
//! belongs to. Files are written atomically ([`crate::atomic`]) and sized against the memory
//! budget before they are read, so a checkpoint is never half-written, and a foreign, damaged,
//! older or other run's file is a clear error (or, for a cache such as a sweep task, a miss).
//!
//! ```
//! use occam::data::checkpoint::{from_bytes, to_bytes};
//! let bytes = to_bytes("demo", 1, "run-42", &vec![1.0, f64::NAN, f64::INFINITY]);
//! let back: Vec<f64> = from_bytes(&bytes, "demo", 1, Some("run-42")).unwrap();
//! assert!(back[0] == 1.0 && back[1].is_nan() && back[2] == f64::INFINITY);
//! assert!(from_bytes::<Vec<f64>>(&bytes, "demo", 1, Some("run-43")).is_err());
//! ```

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The `format` of every occam checkpoint.
pub const FORMAT: &str = "occam-checkpoint";

#[derive(Serialize)]
struct Out<'a, T: ?Sized> {
    format: &'static str,
    kind: &'a str,
    version: u32,
    identity: &'a str,
    payload: &'a T,
}

/// The envelope without its payload (read first, so that a checkpoint of another kind or
/// version is named as such rather than failing inside the payload).
#[derive(Deserialize)]
struct Head {
    format: String,
    kind: String,
    version: u32,
    identity: String,
}

#[derive(Deserialize)]
struct In<T> {
    payload: T,
}

/// Why a checkpoint cannot be used.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum CheckpointError {
    /// The file cannot be read or written.
    #[error("{path}: {what}: {msg}")]
    Io {
        path: PathBuf,
        what: String,
        msg: String,
    },
    /// Not an occam checkpoint, or a damaged one.
    #[error(
        "{path}: not a readable occam checkpoint ({msg}); run without --resume to start afresh"
    )]
    Unreadable { path: PathBuf, msg: String },
    /// A checkpoint of another kind of run (a select checkpoint given to a fit).
    #[error(
        "{path}: a checkpoint of `{found}`, not of `{expected}`; run without --resume to start afresh"
    )]
    Kind {
        path: PathBuf,
        found: String,
        expected: String,
    },
    /// Written by an occam whose checkpoints this one cannot read.
    #[error(
        "{path}: checkpoint version {found} of `{kind}`, this occam reads version {expected}; run without --resume to start afresh"
    )]
    Version {
        path: PathBuf,
        kind: String,
        found: u32,
        expected: u32,
    },
    /// Of a different run (another study, other data, other settings).
    #[error(
        "{path}: the checkpoint belongs to a different run (identity {found}, this run is {expected}): the study, its data or its settings changed; run without --resume to start afresh"
    )]
    Identity {
        path: PathBuf,
        found: String,
        expected: String,
    },
}

/// The bytes of a checkpoint of `kind`, `version` and `identity` holding `payload`.
pub fn to_bytes<T: Serialize + ?Sized>(
    kind: &str,
    version: u32,
    identity: &str,
    payload: &T,
) -> Vec<u8> {
    let mut v = Vec::new();
    ciborium::into_writer(
        &Out {
            format: FORMAT,
            kind,
            version,
            identity,
            payload,
        },
        &mut v,
    )
    .expect("writing CBOR to memory cannot fail");
    v
}

/// The payload of checkpoint bytes, after checking the format, the kind, the version and (when
/// given) the identity. Errors name `"(in memory)"` as the path; [`read`] names the file.
pub fn from_bytes<T: DeserializeOwned>(
    bytes: &[u8],
    kind: &str,
    version: u32,
    identity: Option<&str>,
) -> Result<T, CheckpointError> {
    decode(bytes, Path::new("(in memory)"), kind, version, identity)
}

/// A decoding error in words: ciborium's `Display` is its `Debug` (`Semantic(None, "…")`,
/// `Io(Error { kind: UnexpectedEof, … })`).
fn cbor_error(e: &ciborium::de::Error<std::io::Error>) -> String {
    use ciborium::de::Error;
    match e {
        Error::Io(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends early (cut short while it was written, or not a checkpoint)".into()
        }
        Error::Io(e) => format!("cannot read it: {e}"),
        Error::Syntax(at) => format!("not a checkpoint: no valid CBOR at byte {at}"),
        Error::Semantic(Some(at), msg) => format!("unexpected contents at byte {at}: {msg}"),
        Error::Semantic(None, msg) => format!("unexpected contents: {msg}"),
        Error::RecursionLimitExceeded => "not a checkpoint: nested too deeply".into(),
    }
}

fn decode<T: DeserializeOwned>(
    bytes: &[u8],
    path: &Path,
    kind: &str,
    version: u32,
    identity: Option<&str>,
) -> Result<T, CheckpointError> {
    let unreadable = |msg: String| CheckpointError::Unreadable {
        path: path.to_path_buf(),
        msg,
    };
    let head: Head = ciborium::from_reader(bytes).map_err(|e| {
        // a checkpoint of an occam before this format names itself in a `format` field
        let old = ciborium::from_reader::<ciborium::Value, _>(bytes)
            .ok()
            .and_then(|v| {
                v.as_map()?.iter().find_map(|(k, v)| {
                    (k.as_text()? == "format").then(|| v.as_text().map(str::to_string))?
                })
            });
        match old {
            Some(f) => unreadable(format!("written by an earlier occam, format `{f}`")),
            None => unreadable(cbor_error(&e)),
        }
    })?;
    if head.format != FORMAT {
        return Err(unreadable(format!(
            "format `{}`, expected `{FORMAT}`",
            head.format
        )));
    }
    if head.kind != kind {
        return Err(CheckpointError::Kind {
            path: path.to_path_buf(),
            found: head.kind,
            expected: kind.into(),
        });
    }
    if head.version != version {
        return Err(CheckpointError::Version {
            path: path.to_path_buf(),
            kind: kind.into(),
            found: head.version,
            expected: version,
        });
    }
    if let Some(id) = identity
        && head.identity != id
    {
        return Err(CheckpointError::Identity {
            path: path.to_path_buf(),
            found: head.identity,
            expected: id.into(),
        });
    }
    let body: In<T> = ciborium::from_reader(bytes).map_err(|e| unreadable(cbor_error(&e)))?;
    Ok(body.payload)
}

/// Writes a checkpoint atomically (a temporary file in the same directory, then a rename).
pub fn write<T: Serialize + ?Sized>(
    path: &Path,
    kind: &str,
    version: u32,
    identity: &str,
    payload: &T,
) -> Result<(), CheckpointError> {
    crate::atomic::write_bytes(path, &to_bytes(kind, version, identity, payload)).map_err(|e| {
        CheckpointError::Io {
            path: path.to_path_buf(),
            what: "cannot write the checkpoint".into(),
            msg: e.to_string(),
        }
    })
}

/// Reads the checkpoint at `path` (sized against the memory budget first) and returns its
/// payload after the checks of [`from_bytes`].
pub fn read<T: DeserializeOwned>(
    path: &Path,
    kind: &str,
    version: u32,
    identity: Option<&str>,
) -> Result<T, CheckpointError> {
    let io = |what: &str, msg: String| CheckpointError::Io {
        path: path.to_path_buf(),
        what: what.into(),
        msg,
    };
    let len = std::fs::metadata(path)
        .map_err(|e| io("cannot open", e.to_string()))?
        .len();
    let budget = super::memory::memory_budget_bytes();
    // the decoded payload takes a few times the file's bytes; 4× is generous for CBOR numbers
    if len.saturating_mul(4) > budget {
        return Err(io(
            "too large",
            format!(
                "{len} bytes, beyond the memory budget of {budget} bytes; raise OCCAM_MEMORY_BUDGET if the machine has the memory"
            ),
        ));
    }
    let bytes = super::infile::read(path).map_err(|e| io("cannot read", e.to_string()))?;
    decode(&bytes, path, kind, version, identity)
}

/// The kind and identity of the checkpoint at `path` (its envelope only; the payload is not
/// decoded): whether a file holds the state of a given run, before trying to resume it.
pub fn head(path: &Path) -> Result<(String, String), CheckpointError> {
    let file = super::infile::open(path).map_err(|e| CheckpointError::Io {
        path: path.to_path_buf(),
        what: "cannot open".into(),
        msg: e.to_string(),
    })?;
    // streamed: the payload is skipped, never held
    let reader = std::io::BufReader::new(file);
    let head: Head = ciborium::from_reader(reader).map_err(|e| CheckpointError::Unreadable {
        path: path.to_path_buf(),
        msg: cbor_error(&e),
    })?;
    if head.format != FORMAT {
        return Err(CheckpointError::Unreadable {
            path: path.to_path_buf(),
            msg: format!("format `{}`, expected `{FORMAT}`", head.format),
        });
    }
    Ok((head.kind, head.identity))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct State {
        x: Vec<f64>,
        n: u64,
    }

    fn state() -> State {
        State {
            x: vec![0.1 + 0.2, f64::NAN, f64::NEG_INFINITY, -0.0, 1e-310],
            n: 7,
        }
    }

    #[test]
    fn head_names_kind_and_identity_without_the_payload() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.cbor");
        write(&p, "stage", 3, "run-7", &vec![1.5f64; 1000]).unwrap();
        assert_eq!(
            head(&p).unwrap(),
            ("stage".to_string(), "run-7".to_string())
        );
        std::fs::write(&p, b"not cbor").unwrap();
        assert!(matches!(head(&p), Err(CheckpointError::Unreadable { .. })));
        assert!(matches!(
            head(&dir.path().join("none")),
            Err(CheckpointError::Io { .. })
        ));
    }

    #[test]
    fn a_damaged_checkpoint_is_described_in_words() {
        let b = to_bytes("fit", 2, "abc", &state());
        // cut short, and a payload of another shape
        let e = from_bytes::<State>(&b[..b.len() - 5], "fit", 2, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("the file ends early"), "{e}");
        let e = from_bytes::<Vec<String>>(&b, "fit", 2, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unexpected contents"), "{e}");
        for e in [
            from_bytes::<State>(&b[..b.len() - 5], "fit", 2, None),
            from_bytes::<State>(b"\xff\xff\xff", "fit", 2, None),
        ] {
            let e = e.unwrap_err().to_string();
            assert!(
                !e.contains("Semantic(") && !e.contains("Error {") && !e.contains("kind:"),
                "{e}"
            );
        }
    }

    #[test]
    fn every_bit_survives_a_file_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("checkpoint.cbor");
        write(&p, "fit", 2, "abc", &state()).unwrap();
        let back: State = read(&p, "fit", 2, Some("abc")).unwrap();
        let bits = |s: &State| s.x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&state()));
        assert_eq!(back.n, 7);
        // no temporary file is left beside it
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn another_kind_version_or_run_is_refused_by_name() {
        let b = to_bytes("select", 3, "run-a", &state());
        let e = from_bytes::<State>(&b, "fit", 3, None).unwrap_err();
        assert!(matches!(e, CheckpointError::Kind { .. }), "{e}");
        assert!(e.to_string().contains("`select`, not of `fit`"), "{e}");
        let e = from_bytes::<State>(&b, "select", 4, None).unwrap_err();
        assert!(e.to_string().contains("version 3"), "{e}");
        let e = from_bytes::<State>(&b, "select", 3, Some("run-b")).unwrap_err();
        assert!(matches!(e, CheckpointError::Identity { .. }), "{e}");
        assert!(from_bytes::<State>(&b, "select", 3, None).is_ok());
    }

    #[test]
    fn foreign_and_damaged_files_are_unreadable_not_a_panic() {
        for bytes in [
            &b"{\"format\": \"json\"}"[..],
            &[][..],
            &to_bytes("fit", 1, "a", &state())[..20],
            &to_bytes("fit", 1, "a", &vec![1u8, 2])[..],
        ] {
            let e = from_bytes::<State>(bytes, "fit", 1, None).unwrap_err();
            assert!(
                matches!(e, CheckpointError::Unreadable { .. }),
                "{bytes:?}: {e}"
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let e = read::<State>(&dir.path().join("none.cbor"), "fit", 1, None).unwrap_err();
        assert!(e.to_string().contains("cannot open"), "{e}");
    }
}
