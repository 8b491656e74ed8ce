//! The one writer every output file goes through.
//!
//! What happens depends on what is at the path, after following symbolic links (up to
//! [`MAX_LINK_HOPS`] of them; the links themselves are never touched):
//!
//! * nothing, or a regular file: the bytes go to a temporary file in the same folder, which is
//!   then renamed over the target, so a reader sees the old file or the new one and never half of
//!   either. A replaced file keeps its permissions. Missing parent folders are created.
//! * a FIFO, a character or block device (`/dev/null`, a terminal, `/dev/stdout`): written in
//!   place, never replaced (renaming over a device node would swap it for a plain file).
//! * a folder or a socket: refused, naming the path and what is there.
//!
//! [`Target::Stdout`] (`-` on the command line) writes to standard output.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Symbolic links followed before giving up (Linux's own limit, `MAXSYMLINKS`, is 40).
pub const MAX_LINK_HOPS: usize = 40;

/// Where a command's single output goes: a file, or standard output (`-`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    Stdout,
    File(PathBuf),
}

impl Target {
    /// `-` is standard output; anything else a path.
    pub fn from_arg(arg: &Path) -> Target {
        if arg.as_os_str() == "-" {
            Target::Stdout
        } else {
            Target::File(arg.to_path_buf())
        }
    }

    pub fn is_stdout(&self) -> bool {
        matches!(self, Target::Stdout)
    }

    /// Writes `bytes` to the target.
    pub fn write(&self, bytes: &[u8]) -> Result<()> {
        match self {
            Target::Stdout => write_stdout(bytes),
            Target::File(p) => write(p, bytes),
        }
    }

    /// Checks, before any work, that the target can be written (see [`check_file`]); standard
    /// output always can. `what` names the option that gave the target.
    pub fn check(&self, what: &str) -> Result<()> {
        match self {
            Target::Stdout => Ok(()),
            Target::File(p) => check_file(p, what),
        }
    }

    /// Refuses a target that is one of the command's input files (after links are followed):
    /// writing it would destroy the input. `inputs` pairs each input with the option that gave
    /// it; `what` names the target's option.
    pub fn check_not_input(&self, inputs: &[(&Path, &str)], what: &str) -> Result<()> {
        let Target::File(p) = self else {
            return Ok(());
        };
        let Ok(target) = std::fs::canonicalize(p) else {
            return Ok(()); // not there yet: no input can be it
        };
        for (input, option) in inputs {
            if std::fs::canonicalize(input).is_ok_and(|i| i == target) {
                return Err(Error::file(
                    p,
                    format!("is also the {option} file; writing {what} there would destroy it, so give another path"),
                ));
            }
        }
        Ok(())
    }

    /// How messages name the target.
    pub fn describe(&self) -> String {
        match self {
            Target::Stdout => "standard output".into(),
            Target::File(p) => p.display().to_string(),
        }
    }
}

/// Writes `bytes` to standard output and flushes it.
pub fn write_stdout(bytes: &[u8]) -> Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)
        .and_then(|_| out.flush())
        .map_err(|e| Error::io("standard output", e))
}

/// What the path names once its symbolic links are followed.
#[derive(Debug)]
enum Resolved {
    /// Nothing there yet: the file to create.
    Missing(PathBuf),
    Regular(PathBuf, std::fs::Metadata),
    /// A FIFO or a device: written through this path, in place (truncated first if the kernel
    /// says it is a regular file reached through a magic link).
    InPlace(PathBuf, bool),
}

/// Nothing at the path: not found, or a path through a file (`file/sub`).
fn is_missing(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::NotFound | std::io::ErrorKind::NotADirectory
    )
}

/// Follows `path`'s symbolic links to what they name. The links under `/proc` behind
/// `/dev/stdout` and `/dev/fd/N` name an open descriptor, not a path (`pipe:[…]`, or a file
/// the shell opened): what they reach is written in place, through the original path.
fn resolve(path: &Path) -> Result<Resolved> {
    use std::os::unix::fs::FileTypeExt;
    let mut p = path.to_path_buf();
    for _ in 0..=MAX_LINK_HOPS {
        let meta = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            // a dangling link, or a plain missing file: create what it names (a path through a
            // file is missing too; making its folder fails, or the check names the file)
            Err(e) if is_missing(&e) => return Ok(Resolved::Missing(p)),
            Err(e) => return Err(Error::io(&p, e)),
        };
        let ft = meta.file_type();
        if ft.is_symlink() && p.starts_with("/proc") {
            let m = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
            if m.is_dir() {
                return Err(Error::file(
                    path,
                    "is a folder; give the path of a file to write (or - for standard output)",
                ));
            }
            return Ok(Resolved::InPlace(path.to_path_buf(), m.is_file()));
        }
        if ft.is_symlink() {
            let target = std::fs::read_link(&p).map_err(|e| Error::io(&p, e))?;
            p = if target.is_absolute() {
                target
            } else {
                p.parent().unwrap_or(Path::new("")).join(target)
            };
            continue;
        }
        if ft.is_file() {
            return Ok(Resolved::Regular(p, meta));
        }
        if ft.is_dir() {
            return Err(Error::file(
                path,
                "is a folder; give the path of a file to write (or - for standard output)",
            ));
        }
        if ft.is_socket() {
            return Err(Error::file(
                path,
                "is a socket; furnace writes regular files, FIFOs and devices (or - for standard output)",
            ));
        }
        // FIFO, character or block device
        return Ok(Resolved::InPlace(p, false));
    }
    Err(Error::file(
        path,
        format!(
            "more than {MAX_LINK_HOPS} symbolic links in a row (a loop?); give the file itself"
        ),
    ))
}

/// A temporary path in `dir`, unique within this process and hidden: `.<name>.tmp-<pid>-<n><suffix>`.
fn temp_path(target: &Path, suffix: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = target
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let file = format!(".{name}.tmp-{}-{n}{suffix}", std::process::id());
    match target.parent() {
        Some(d) => d.join(file),
        None => PathBuf::from(file),
    }
}

fn create_parent(path: &Path) -> Result<()> {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => {
            std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))
        }
        _ => Ok(()),
    }
}

/// Writes `bytes` to `path` (see the module documentation for what "write" means for each kind
/// of file).
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    match resolve(path)? {
        Resolved::InPlace(p, truncate) => write_in_place(&p, path, bytes, truncate),
        other => commit(other, path, "", |tmp| {
            std::fs::write(tmp, bytes).map_err(|e| Error::io(path, e))
        }),
    }
}

/// Like [`write`], for producers that write a file themselves (an image encoder): `produce`
/// writes the whole file at the temporary path it is given, which ends in `suffix` (encoders
/// that pick the format from the extension need it). For a FIFO or device target the temporary
/// file is made in the system's temporary folder, copied into the target and removed.
pub fn write_with(
    path: &Path,
    suffix: &str,
    produce: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    match resolve(path)? {
        Resolved::InPlace(p, truncate) => {
            let tmp = temp_path(&std::env::temp_dir().join("furnace-out"), suffix);
            let result = produce(&tmp).and_then(|_| {
                let bytes = std::fs::read(&tmp).map_err(|e| Error::io(&tmp, e))?;
                write_in_place(&p, path, &bytes, truncate)
            });
            let _ = std::fs::remove_file(&tmp);
            result
        }
        other => commit(other, path, suffix, produce),
    }
}

/// A temporary file next to the target, renamed over it: for a missing or regular target.
fn commit(
    resolved: Resolved,
    named: &Path,
    suffix: &str,
    produce: impl FnOnce(&Path) -> Result<()>,
) -> Result<()> {
    let (p, permissions) = match resolved {
        Resolved::Missing(p) => {
            create_parent(&p)?;
            (p, None)
        }
        Resolved::Regular(p, meta) => (p, Some(meta.permissions())),
        Resolved::InPlace(..) => unreachable!("in-place targets are written by the caller"),
    };
    let tmp = temp_path(&p, suffix);
    let result = produce(&tmp)
        .and_then(|_| match permissions {
            Some(perm) => std::fs::set_permissions(&tmp, perm).map_err(|e| Error::io(named, e)),
            None => Ok(()),
        })
        .and_then(|_| std::fs::rename(&tmp, &p).map_err(|e| Error::io(named, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Opens a FIFO or device for writing (no create, no truncate) and writes everything.
fn write_in_place(p: &Path, named: &Path, bytes: &[u8], truncate: bool) -> Result<()> {
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .truncate(truncate)
        .open(p)
        .map_err(|e| Error::io(named, e))?;
    f.write_all(bytes)
        .and_then(|_| f.flush())
        .map_err(|e| Error::io(named, e))
}

/// Makes sure files can be written under `dir` (creating it): a probe file is created and
/// removed. Commands call this for their output folders before computing anything, so an
/// unwritable folder fails in a second, not after the work. `what` names the folder's option.
pub fn check_writable_dir(dir: &Path, what: &str) -> Result<()> {
    let fix = |e: std::io::Error| {
        Error::file(
            dir,
            format!("cannot write here ({e}); choose another folder with {what}"),
        )
    };
    std::fs::create_dir_all(dir).map_err(fix)?;
    let probe = temp_path(&dir.join("probe"), "");
    std::fs::write(&probe, b"").map_err(fix)?;
    std::fs::remove_file(&probe).map_err(fix)
}

/// Makes sure [`write`] can write `path`, without creating or changing anything: a FIFO or a
/// device is written in place and needs nothing more; for a missing or regular file (after its
/// links are followed) the folder it goes in must be writable, or be creatable in the nearest
/// folder that exists. Commands call this for their output file before computing anything.
/// `what` names the option that gave the path.
pub fn check_file(path: &Path, what: &str) -> Result<()> {
    match resolve(path)? {
        Resolved::InPlace(..) => Ok(()),
        Resolved::Missing(p) | Resolved::Regular(p, _) => {
            let dir = match p.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            check_dir_creatable(&dir, what)
        }
    }
}

/// Makes sure files can be written under `dir` without creating it: the nearest folder of `dir`
/// and its parents that exists must be a folder in which a probe file can be made (the probe is
/// removed). A path that runs through a file, or an unwritable folder, is refused naming `what`.
pub fn check_dir_creatable(dir: &Path, what: &str) -> Result<()> {
    let mut existing = dir.to_path_buf();
    loop {
        match std::fs::metadata(&existing) {
            Ok(m) if m.is_dir() => break,
            Ok(_) => {
                return Err(Error::file(
                    dir,
                    format!(
                        "cannot write here: {} is not a folder; choose another path with {what}",
                        existing.display()
                    ),
                ))
            }
            Err(e) if is_missing(&e) => {}
            Err(e) => {
                return Err(Error::file(
                    dir,
                    format!("cannot write here ({e}); choose another path with {what}"),
                ))
            }
        }
        existing = match existing.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
    }
    let probe = temp_path(&existing.join("probe"), "");
    std::fs::write(&probe, b"")
        .and_then(|_| std::fs::remove_file(&probe))
        .map_err(|e| {
            Error::file(
                dir,
                format!("cannot write here ({e}); choose another path with {what}"),
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::{symlink, FileTypeExt, PermissionsExt};

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("furnace-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn regular_files_are_replaced_atomically_keeping_permissions() {
        let d = scratch("regular");
        let f = d.join("sub/out.csv");
        write(&f, b"one").unwrap();
        assert_eq!(std::fs::read(&f).unwrap(), b"one");
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o600)).unwrap();
        let before = std::fs::metadata(&f).unwrap();
        write(&f, b"two").unwrap();
        let after = std::fs::metadata(&f).unwrap();
        assert_eq!(std::fs::read(&f).unwrap(), b"two");
        assert_eq!(after.permissions().mode() & 0o777, 0o600);
        use std::os::unix::fs::MetadataExt;
        assert_ne!(
            before.ino(),
            after.ino(),
            "a new file was renamed into place"
        );
        assert_eq!(names(&d.join("sub")), ["out.csv"], "no temporary file left");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_symlink_is_followed_and_its_target_written() {
        let d = scratch("symlink");
        let target = d.join("real.csv");
        std::fs::write(&target, b"old").unwrap();
        symlink("real.csv", d.join("link.csv")).unwrap();
        symlink("link.csv", d.join("link2.csv")).unwrap();
        write(&d.join("link2.csv"), b"new").unwrap();
        assert!(std::fs::symlink_metadata(d.join("link.csv"))
            .unwrap()
            .file_type()
            .is_symlink());
        assert!(std::fs::symlink_metadata(d.join("link2.csv"))
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        // a dangling link: its target is created, the link stays
        symlink("made/by/link.csv", d.join("dangling.csv")).unwrap();
        write(&d.join("dangling.csv"), b"x").unwrap();
        assert_eq!(std::fs::read(d.join("made/by/link.csv")).unwrap(), b"x");
        assert!(std::fs::symlink_metadata(d.join("dangling.csv"))
            .unwrap()
            .file_type()
            .is_symlink());
        // a loop is refused by name
        symlink("loop-b", d.join("loop-a")).unwrap();
        symlink("loop-a", d.join("loop-b")).unwrap();
        let e = write(&d.join("loop-a"), b"x").unwrap_err().to_string();
        assert!(e.contains("symbolic links in a row"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_fifo_is_written_in_place_and_stays_a_fifo() {
        let d = scratch("fifo");
        let fifo = d.join("pipe");
        let ok = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(ok.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(&fifo).unwrap())
        };
        write(&fifo, b"through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), b"through the pipe");
        assert!(std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo());
        assert_eq!(names(&d), ["pipe"]);
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn folders_are_refused_and_probed() {
        let d = scratch("folder");
        let e = write(&d, b"x").unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        check_writable_dir(&d.join("new/deeper"), "--fits-dir").unwrap();
        assert!(d.join("new/deeper").is_dir());
        assert!(names(&d.join("new/deeper")).is_empty());
        std::fs::write(d.join("plain"), b"").unwrap();
        let e = check_writable_dir(&d.join("plain/sub"), "--fits-dir")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cannot write here") && e.contains("--fits-dir"),
            "{e}"
        );
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn output_files_are_checked_without_creating_anything() {
        let d = scratch("check");
        // a new file in folders still to be made, a regular file, a FIFO: all writable
        check_file(&d.join("new/deeper/out.csv"), "--output").unwrap();
        assert!(!d.join("new").exists(), "the check creates nothing");
        std::fs::write(d.join("old.csv"), b"x").unwrap();
        check_file(&d.join("old.csv"), "--output").unwrap();
        let fifo = d.join("pipe");
        if std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success())
        {
            // opening a FIFO for writing would block: the check must not open it
            check_file(&fifo, "--output").unwrap();
        }
        Target::Stdout.check("--output").unwrap();
        assert!(
            names(&d).iter().all(|n| n == "old.csv" || n == "pipe"),
            "the probes are removed: {:?}",
            names(&d)
        );
        // a path through a file, and a folder, are refused naming the option
        std::fs::write(d.join("plain"), b"").unwrap();
        let e = check_file(&d.join("plain/sub/out.csv"), "--output")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("is not a folder") && e.contains("plain") && e.contains("--output"),
            "{e}"
        );
        let e = check_dir_creatable(&d.join("plain/fits"), "--fits-dir")
            .unwrap_err()
            .to_string();
        assert!(e.contains("--fits-dir"), "{e}");
        let e = check_file(&d, "--output").unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn dash_is_standard_output() {
        assert_eq!(Target::from_arg(Path::new("-")), Target::Stdout);
        assert_eq!(
            Target::from_arg(Path::new("./-")),
            Target::File(PathBuf::from("./-"))
        );
    }
}
