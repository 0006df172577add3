//! Run directories: each run's outputs are one consistent set.
//!
//! A command that writes into a directory opens it as a [`RunDir`] *before* computing
//! anything, which
//! - creates it and proves it writable (a probe file), so an unwritable directory is found
//!   in a second, not after an hour of sampling;
//! - takes an exclusive lock on `.occam.lock` (an OS file lock, released by the kernel when
//!   the process ends, even on `kill -9`; the file is removed when the run ends), so a second
//!   run on the same directory is refused instead of interleaving its files with the first;
//! - removes what a killed run left: temporaries `.<name>.tmp…` and a `.staging` directory.
//!
//! The outputs are written into `.staging` and then published: the old `manifest.json` is
//! removed first, the files of the previous run that this one does not write are removed
//! (a figure the new run skipped must not stay behind looking current), the staged files are
//! renamed into place and `manifest.json` — the list of the run's files with their sizes — is
//! written last. A directory whose `manifest.json` is missing was interrupted while
//! publishing; the files a manifest lists are exactly those of one run.

use serde::{Deserialize, Serialize};
use std::fs::File;
use std::path::{Path, PathBuf};

/// The file listing a finished run's outputs, written last.
pub const MANIFEST: &str = "manifest.json";
const LOCK: &str = ".occam.lock";
const STAGING: &str = ".staging";
const PROBE: &str = ".occam-write-test";

/// Why a run directory cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    #[error(
        "{dir}: cannot use it as the output directory: {what}: {source}; choose another with -o/--output"
    )]
    Io {
        dir: PathBuf,
        what: String,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{dir}: another occam run is writing into this directory ({holder}); wait for it to finish or choose another directory with -o/--output"
    )]
    Busy { dir: PathBuf, holder: String },
}

/// One published file of a run.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ManifestEntry {
    pub name: String,
    pub bytes: u64,
}

/// `manifest.json`: what a finished run wrote.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    pub format: String,
    /// The command that wrote the directory (`fit`, `select`, …).
    pub command: String,
    /// The occam version that wrote it.
    pub version: String,
    pub files: Vec<ManifestEntry>,
}

impl Manifest {
    /// Reads `dir/manifest.json`, if there is one that parses.
    pub fn read(dir: &Path) -> Option<Manifest> {
        let text = std::fs::read_to_string(dir.join(MANIFEST)).ok()?;
        serde_json::from_str(&text).ok()
    }
}

/// An output directory held by this process for one run (see the module docs).
#[derive(Debug)]
pub struct RunDir {
    dir: PathBuf,
    // held for the lifetime of the run: the lock goes when the file is closed
    _lock: File,
}

fn io(dir: &Path, what: &str) -> impl FnOnce(std::io::Error) -> RunDirError {
    let dir = dir.to_path_buf();
    let what = what.to_string();
    move |source| RunDirError::Io { dir, what, source }
}

/// Whether `name` is a temporary of an atomic write (`.<name>.tmp-<pid>`) or of a checkpoint
/// (`.<name>.tmp`) — and not, say, a user's `.notes.tmpl`.
fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && (name.ends_with(".tmp") || name.contains(".tmp-"))
}

/// Whether `name` matches `pattern`, in which one `*` stands for any run of characters.
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((pre, post)) => {
            name.len() >= pre.len() + post.len() && name.starts_with(pre) && name.ends_with(post)
        }
    }
}

/// Removes the temporaries a killed run left in `dir` (not recursive).
pub fn remove_temporaries(dir: &Path) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if is_temporary(&name) && e.path().is_file() {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Whether the open `file` is the one at `path` now.
#[cfg(unix)]
fn same_file(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &File, _: &Path) -> bool {
    true
}

impl Drop for RunDir {
    fn drop(&mut self) {
        // removed while still locked, so a run that opens it meanwhile sees it vanish
        // (`same_file`) and starts over on a new one; a killed run leaves it, unlocked
        #[cfg(unix)]
        let _ = std::fs::remove_file(self.dir.join(LOCK));
    }
}

impl RunDir {
    /// Creates `dir` if needed, locks it, checks that it is writable and removes what a
    /// killed run left behind.
    pub fn open(dir: &Path) -> Result<RunDir, RunDirError> {
        std::fs::create_dir_all(dir).map_err(io(dir, "cannot create it"))?;
        let run = Self::lock(dir)?;
        let probe = dir.join(PROBE);
        std::fs::write(&probe, b"").map_err(io(dir, "it is not writable"))?;
        let _ = std::fs::remove_file(&probe);
        remove_temporaries(dir);
        let staging = dir.join(STAGING);
        if staging.exists() {
            std::fs::remove_dir_all(&staging)
                .map_err(io(dir, "cannot remove a killed run's .staging directory"))?;
        }
        Ok(run)
    }

    /// Locks an existing run directory and nothing else: no directory is created and nothing
    /// a killed run left is removed, for a command that adds one file to a finished run
    /// (`occam report`) without being a new run of it.
    pub fn lock(dir: &Path) -> Result<RunDir, RunDirError> {
        let lock_path = dir.join(LOCK);
        let lock = loop {
            let lock = std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .read(true)
                .write(true)
                .open(&lock_path)
                .map_err(io(dir, "cannot create the lock file .occam.lock"))?;
            match lock.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let holder = std::fs::read_to_string(&lock_path)
                        .ok()
                        .and_then(|s| s.trim().parse::<u32>().ok())
                        .map_or("process unknown".to_string(), |p| format!("process {p}"));
                    return Err(RunDirError::Busy {
                        dir: dir.to_path_buf(),
                        holder,
                    });
                }
                Err(std::fs::TryLockError::Error(e)) => {
                    return Err(io(dir, "cannot lock .occam.lock")(e));
                }
            }
            // the run that held it may have removed the file between our open and our lock
            // (it removes it when it ends): then we hold a lock on a file nobody else sees
            if same_file(&lock, &lock_path) {
                break lock;
            }
        };
        // who holds it, for the message of a refused second run
        {
            use std::io::{Seek, Write};
            let mut f = &lock;
            let _ = f.set_len(0);
            let _ = f.seek(std::io::SeekFrom::Start(0));
            let _ = writeln!(f, "{}", std::process::id());
        }
        Ok(RunDir {
            dir: dir.to_path_buf(),
            _lock: lock,
        })
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// A fresh, empty staging directory inside the run directory: write the outputs there,
    /// then [`publish`](Self::publish) them.
    pub fn staging(&self) -> Result<PathBuf, RunDirError> {
        let s = self.dir.join(STAGING);
        if s.exists() {
            std::fs::remove_dir_all(&s).map_err(io(&self.dir, "cannot clear .staging"))?;
        }
        std::fs::create_dir_all(&s).map_err(io(&self.dir, "cannot create .staging"))?;
        Ok(s)
    }

    /// Publishes every file staged by [`staging`](Self::staging): removes the old manifest and
    /// the previous run's files that this run did not write (those the old manifest lists,
    /// or for a directory written before manifests existed, the files matching the `legacy`
    /// patterns of this command's outputs, where `*` stands for any run of characters), moves the staged files into place and writes the manifest.
    /// Returns the published file names, sorted.
    pub fn publish(&self, command: &str, legacy: &[&str]) -> Result<Vec<String>, RunDirError> {
        let staging = self.dir.join(STAGING);
        let mut files: Vec<ManifestEntry> = Vec::new();
        let rd = std::fs::read_dir(&staging).map_err(io(&self.dir, "cannot read .staging"))?;
        for e in rd {
            let e = e.map_err(io(&self.dir, "cannot read .staging"))?;
            let meta = e
                .metadata()
                .map_err(io(&self.dir, "cannot read .staging"))?;
            let name = e.file_name().to_string_lossy().into_owned();
            if meta.is_file() && !is_temporary(&name) {
                files.push(ManifestEntry {
                    name,
                    bytes: meta.len(),
                });
            }
        }
        files.sort_by(|a, b| a.name.cmp(&b.name));
        let new: Vec<&str> = files.iter().map(|f| f.name.as_str()).collect();
        let old: Vec<String> = match Manifest::read(&self.dir) {
            Some(m) => m.files.into_iter().map(|f| f.name).collect(),
            None => std::fs::read_dir(&self.dir)
                .map(|rd| {
                    rd.flatten()
                        .map(|e| e.file_name().to_string_lossy().into_owned())
                        .filter(|n| legacy.iter().any(|p| matches(p, n)))
                        .collect()
                })
                .unwrap_or_default(),
        };
        let manifest = self.dir.join(MANIFEST);
        if manifest.exists() {
            std::fs::remove_file(&manifest)
                .map_err(io(&self.dir, "cannot remove manifest.json"))?;
        }
        for name in old.iter().filter(|n| !new.contains(&n.as_str())) {
            // names come from a file we wrote, but never let one escape the directory
            if Path::new(name).components().count() == 1 {
                let _ = std::fs::remove_file(self.dir.join(name));
            }
        }
        for f in &files {
            std::fs::rename(staging.join(&f.name), self.dir.join(&f.name))
                .map_err(io(&self.dir, &format!("cannot move {} into place", f.name)))?;
        }
        let m = Manifest {
            format: "occam-run".into(),
            command: command.into(),
            version: env!("CARGO_PKG_VERSION").into(),
            files,
        };
        let json = serde_json::to_string_pretty(&m).expect("manifest serialises") + "\n";
        crate::atomic::write_bytes(&manifest, json.as_bytes())
            .map_err(io(&self.dir, "cannot write manifest.json"))?;
        let _ = std::fs::remove_dir_all(&staging);
        Ok(m.files.into_iter().map(|f| f.name).collect())
    }
}

impl RunDir {
    /// Adds `name`, a file already in place in the directory, to the finished run's
    /// `manifest.json` (or updates its size), so that the command's next run removes it with
    /// the rest of the old outputs. Returns false, changing nothing, when the directory has
    /// no readable manifest (a run that predates manifests, or one interrupted while
    /// publishing: a manifest written now would vouch for files of unknown origin).
    pub fn record(&self, name: &str) -> Result<bool, RunDirError> {
        let Some(mut m) = Manifest::read(&self.dir) else {
            return Ok(false);
        };
        let bytes = std::fs::metadata(self.dir.join(name))
            .map_err(io(&self.dir, &format!("cannot read {name}")))?
            .len();
        match m.files.iter_mut().find(|f| f.name == name) {
            Some(f) => f.bytes = bytes,
            None => {
                m.files.push(ManifestEntry {
                    name: name.into(),
                    bytes,
                });
                m.files.sort_by(|a, b| a.name.cmp(&b.name));
            }
        }
        let json = serde_json::to_string_pretty(&m).expect("manifest serialises") + "\n";
        crate::atomic::write_bytes(&self.dir.join(MANIFEST), json.as_bytes())
            .map_err(io(&self.dir, "cannot write manifest.json"))?;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn publishes_one_consistent_set_and_removes_stale_files() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path().join("run");
        {
            let r = RunDir::open(&d).unwrap();
            let s = r.staging().unwrap();
            std::fs::write(s.join("a.json"), b"1").unwrap();
            std::fs::write(s.join("plot.png"), b"22").unwrap();
            assert_eq!(r.publish("fit", &[]).unwrap(), ["a.json", "plot.png"]);
        }
        let m = Manifest::read(&d).unwrap();
        assert_eq!(m.command, "fit");
        assert_eq!(m.files[1].bytes, 2);
        // a second run that skips the plot: the old plot must not stay behind
        let r = RunDir::open(&d).unwrap();
        let s = r.staging().unwrap();
        std::fs::write(s.join("a.json"), b"new").unwrap();
        assert_eq!(r.publish("fit", &[]).unwrap(), ["a.json"]);
        assert_eq!(std::fs::read(d.join("a.json")).unwrap(), b"new");
        drop(r);
        assert_eq!(names(&d), ["a.json", "manifest.json"]);
    }

    #[test]
    fn legacy_directories_lose_only_the_named_outputs() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        std::fs::write(d.join("corner.png"), b"old").unwrap();
        std::fs::write(d.join("notes.txt"), b"the user's").unwrap();
        let r = RunDir::open(d).unwrap();
        let s = r.staging().unwrap();
        std::fs::write(s.join("summary.json"), b"{}").unwrap();
        std::fs::write(d.join("residual_psd_inv1.png"), b"old").unwrap();
        r.publish("fit", &["corner.png", "summary.json", "residual_psd_*.png"])
            .unwrap();
        assert!(!d.join("corner.png").exists());
        assert!(!d.join("residual_psd_inv1.png").exists());
        assert!(d.join("summary.json").exists());
        assert!(d.join("notes.txt").exists());
    }

    #[test]
    fn lock_only_keeps_what_a_run_left_and_record_adds_to_the_manifest() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        {
            let r = RunDir::open(d).unwrap();
            let s = r.staging().unwrap();
            std::fs::write(s.join("a.json"), b"1").unwrap();
            r.publish("fit", &[]).unwrap();
        }
        std::fs::write(d.join(".a.json.tmp-99"), b"x").unwrap();
        std::fs::create_dir_all(d.join(STAGING)).unwrap();
        let r = RunDir::lock(d).unwrap();
        assert!(RunDir::lock(d).is_err(), "a second holder must be refused");
        assert!(d.join(".a.json.tmp-99").exists() && d.join(STAGING).exists());
        std::fs::write(d.join("report.html"), b"four").unwrap();
        assert!(r.record("report.html").unwrap());
        std::fs::write(d.join("report.html"), b"seven").unwrap();
        assert!(r.record("report.html").unwrap());
        let m = Manifest::read(d).unwrap();
        let names: Vec<&str> = m.files.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["a.json", "report.html"]);
        assert_eq!(m.files[1].bytes, 5);
        assert_eq!(m.command, "fit");
        drop(r);
        // the next run of the command does not write it: it goes as a stale output
        let r = RunDir::open(d).unwrap();
        let s = r.staging().unwrap();
        std::fs::write(s.join("a.json"), b"2").unwrap();
        r.publish("fit", &[]).unwrap();
        assert!(!d.join("report.html").exists());
        // without a manifest nothing is recorded
        std::fs::remove_file(d.join(MANIFEST)).unwrap();
        std::fs::write(d.join("report.html"), b"x").unwrap();
        assert!(!r.record("report.html").unwrap());
        assert!(!d.join(MANIFEST).exists());
        // a directory that does not exist is not created by a lock
        assert!(RunDir::lock(&d.join("missing")).is_err());
        assert!(!d.join("missing").exists());
    }

    #[test]
    fn patterns_match_one_wildcard() {
        assert!(matches("a.png", "a.png"));
        assert!(!matches("a.png", "b.png"));
        assert!(matches("ln_b_vs_*.svg", "ln_b_vs_snr.svg"));
        assert!(matches("ln_b_vs_*.svg", "ln_b_vs_.svg"));
        assert!(!matches("ln_b_vs_*.svg", "ln_b_vs_snr.png"));
        assert!(!matches("ab*ba", "aba"));
    }

    #[test]
    fn a_second_run_on_the_same_directory_is_refused_while_the_first_holds_it() {
        let tmp = tempfile::tempdir().unwrap();
        let first = RunDir::open(tmp.path()).unwrap();
        let err = RunDir::open(tmp.path()).unwrap_err().to_string();
        assert!(err.contains("another occam run"), "{err}");
        assert!(
            err.contains(&format!("process {}", std::process::id())),
            "{err}"
        );
        drop(first);
        RunDir::open(tmp.path()).unwrap();
    }

    #[test]
    fn temporaries_and_staging_of_a_killed_run_are_removed() {
        let tmp = tempfile::tempdir().unwrap();
        let d = tmp.path();
        std::fs::write(d.join(".summary.json.tmp-4242"), b"x").unwrap();
        std::fs::write(d.join(".checkpoint.json.tmp"), b"x").unwrap();
        std::fs::create_dir_all(d.join(STAGING)).unwrap();
        std::fs::write(d.join(STAGING).join("half.npz"), b"x").unwrap();
        std::fs::write(d.join("checkpoint.json"), b"kept").unwrap();
        std::fs::write(d.join(".notes.tmpl"), b"the user's").unwrap();
        let _r = RunDir::open(d).unwrap();
        assert_eq!(names(d), [".notes.tmpl", ".occam.lock", "checkpoint.json"]);
    }

    #[test]
    fn a_directory_that_cannot_be_created_is_refused_before_any_work() {
        // a path below a regular file cannot be created, whoever runs the test (root ignores
        // permission bits)
        let tmp = tempfile::tempdir().unwrap();
        let file = tmp.path().join("plain");
        std::fs::write(&file, b"").unwrap();
        let e = RunDir::open(&file.join("out")).unwrap_err().to_string();
        assert!(e.contains("plain/out") && e.contains("-o/--output"), "{e}");
    }
}
