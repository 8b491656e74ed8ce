//! What the documentation tests share: a copy of the repository as a fresh clone has it, in a
//! folder with no siblings, and running a shell command there with `furnace` on the `PATH`; and
//! what the command-line tests share: running `furnace` in a folder, scratch folders.

// every test crate that includes this module uses some of its helpers, never all
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `furnace` under test in `dir`.
pub fn furnace(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_furnace"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the furnace binary runs")
}

/// An empty scratch folder `<tmp>/furnace-<test crate>-<pid>-<name>`.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "furnace-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The standard error of a finished command.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The repository (the package root).
pub fn repository() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The repository's files as a clone has them: `git ls-files` when git tracks the repository,
/// else every file except `target/`, `.git/` and the git-ignored caches under `data/` (as in
/// a source archive).
fn repository_files() -> Vec<PathBuf> {
    let root = repository();
    let git = Command::new("git")
        .args(["ls-files", "-z"])
        .current_dir(&root)
        .output();
    if let Ok(o) = git {
        if o.status.success() && !o.stdout.is_empty() {
            return o
                .stdout
                .split(|&b| b == 0)
                .filter(|p| !p.is_empty())
                .map(|p| PathBuf::from(String::from_utf8_lossy(p).into_owned()))
                .filter(|p| root.join(p).is_file())
                .collect();
        }
    }
    fn walk(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(root.join(rel)) else {
            return;
        };
        for e in entries.flatten() {
            let rel = rel.join(e.file_name());
            let top: Vec<_> = rel.components().map(|c| c.as_os_str().to_owned()).collect();
            let skip = top[0] == "target"
                || top[0] == ".git"
                || (top[0] == "data"
                    && top.len() > 1
                    && !["lut", "paper", "reference"].iter().any(|k| top[1] == *k));
            if skip {
                continue;
            }
            if e.path().is_dir() {
                walk(root, &rel, out);
            } else {
                out.push(rel);
            }
        }
    }
    let mut out = Vec::new();
    walk(&root, Path::new(""), &mut out);
    out
}

/// A fresh copy of the repository at `<tmp>/furnace-<what>-<pid>/furnace`: its parent folder
/// holds nothing else, so a path that leaves the repository (into a sibling folder) finds nothing.
pub fn fresh_copy(what: &str) -> PathBuf {
    let parent = std::env::temp_dir().join(format!("furnace-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&parent);
    let dest = parent.join("furnace");
    let root = repository();
    for rel in repository_files() {
        let to = dest.join(&rel);
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(root.join(&rel), &to)
            .unwrap_or_else(|e| panic!("copying {}: {e}", rel.display()));
    }
    dest
}

/// Runs `line` with `sh -c` in `dir`, with the `furnace` under test first on the `PATH`.
pub fn shell(line: &str, dir: &Path) -> Output {
    let bin = Path::new(env!("CARGO_BIN_EXE_furnace")).parent().unwrap();
    let path = std::env::var_os("PATH").unwrap_or_default();
    let mut paths = vec![bin.to_path_buf()];
    paths.extend(std::env::split_paths(&path));
    Command::new("sh")
        .args(["-c", line])
        .current_dir(dir)
        .env("PATH", std::env::join_paths(paths).unwrap())
        .env_remove("FURNACE_PAPER_DATA")
        .output()
        .expect("sh runs")
}

/// stdout and stderr of a finished command, for failure messages.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}
