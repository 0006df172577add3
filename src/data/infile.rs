//! Opening input files: occam reads regular files only. A FIFO, a device or a socket named as
//! a study, data, injection or checkpoint file would block forever (a FIFO without a writer)
//! or never end (`/dev/zero`), so it is refused by name before it is opened; a directory gets
//! the same clear refusal instead of the platform's "Is a directory".
//!
//! ```
//! let e = occam::data::infile::read(std::path::Path::new("/dev/zero")).unwrap_err();
//! assert!(e.to_string().contains("a character device"), "{e}");
//! ```

use std::fs::File;
use std::io;
use std::path::Path;

/// What kind of file other than a regular one `path` is (`None` for a regular file, or a
/// symbolic link to one). Errors are the platform's (a missing file, no permission).
pub fn not_regular(path: &Path) -> io::Result<Option<&'static str>> {
    let t = std::fs::metadata(path)?.file_type();
    if t.is_file() {
        return Ok(None);
    }
    if t.is_dir() {
        return Ok(Some("a directory"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Ok(Some("a FIFO (named pipe)"));
        }
        if t.is_char_device() {
            return Ok(Some("a character device"));
        }
        if t.is_block_device() {
            return Ok(Some("a block device"));
        }
        if t.is_socket() {
            return Ok(Some("a socket"));
        }
    }
    Ok(Some("not a regular file"))
}

/// Checks that `path` is a regular file before anything opens it.
pub fn check(path: &Path) -> io::Result<()> {
    match not_regular(path)? {
        None => Ok(()),
        Some(kind) => Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{kind}, not a regular file: occam reads only regular files (write the data to a file and name that)"
            ),
        )),
    }
}

/// Opens the regular file `path` for reading ([`check`] first).
pub fn open(path: &Path) -> io::Result<File> {
    check(path)?;
    File::open(path)
}

/// The bytes of the regular file `path`.
pub fn read(path: &Path) -> io::Result<Vec<u8>> {
    check(path)?;
    std::fs::read(path)
}

/// The text of the regular file `path`.
pub fn read_to_string(path: &Path) -> io::Result<String> {
    check(path)?;
    std::fs::read_to_string(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regular_files_are_read_and_others_named() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, "x").unwrap();
        assert_eq!(read_to_string(&f).unwrap(), "x");
        assert_eq!(
            not_regular(dir.path()).unwrap(),
            Some("a directory"),
            "a directory"
        );
        let e = read(dir.path()).unwrap_err();
        assert!(
            e.to_string().contains("a directory, not a regular file"),
            "{e}"
        );
        assert_eq!(
            read(&dir.path().join("missing")).unwrap_err().kind(),
            io::ErrorKind::NotFound
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("pipe");
        let ok = std::process::Command::new("mkfifo").arg(&p).status();
        if !ok.is_ok_and(|s| s.success()) {
            panic!("mkfifo is needed for this test");
        }
        // opening a FIFO without a writer would block this test forever
        let e = open(&p).unwrap_err();
        assert!(e.to_string().starts_with("a FIFO"), "{e}");
        let e = read(Path::new("/dev/zero")).unwrap_err();
        assert!(e.to_string().starts_with("a character device"), "{e}");
    }
}
