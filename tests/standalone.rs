//! The repository stands alone: a clone with no sibling folders has everything the tests, the
//! report, `compare-paper` and the benchmarks read.
//!
//! 1. No source file names a path outside the repository (a literal that climbs out with `..`,
//!    an absolute path into someone's machine, or the sibling folders the vendored data came
//!    from).
//! 2. The README's set-up command, `furnace run`, at small sizes, in a copy of the repository
//!    whose folder has nothing beside it, finds the paper's data (the report sets furnace beside
//!    the paper) and the reference albedos (the quadrature benchmark measures against them).
//!
//! `bash .ci/run --clone` runs the whole suite in such a clone.

mod common;

use std::path::{Path, PathBuf};

/// Literals that are not paths, allowed by file: (file, the exact text).
const NOT_PATHS: &[(&str, &str)] = &[
    // a scene whose name tries to leave the fits folder, which the test expects to be refused
    ("src/scene.rs", r#""../x""#),
];

/// What no source may contain: climbing out of the repository, absolute paths of a particular
/// machine, and the folders beside the repository that the vendored data came from.
const FORBIDDEN: &[&str] = &[
    "\"../",
    "\"..\"",
    "/../",
    "\"/work",
    "\"/home/",
    "\"/root",
    "\"/Users/",
    "shared/paper-repo-data",
    "shared/reference",
    "paper-repo-data\"",
];

fn sources(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs" || x == "toml") {
                out.push(p);
            }
        }
    }
    let mut out = vec![root.join("Cargo.toml"), root.join(".ci/run")];
    for d in ["src", "tests", "examples"] {
        walk(&root.join(d), &mut out);
    }
    out
}

#[test]
fn no_source_path_leaves_the_repository() {
    let root = common::repository();
    let this = file!().replace('\\', "/");
    let mut found = Vec::new();
    for path in sources(&root) {
        let rel = path
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if this.ends_with(&rel) {
            continue; // the patterns themselves
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut line = line.to_string();
            for (file, allowed) in NOT_PATHS {
                if rel == *file {
                    line = line.replace(allowed, "");
                }
            }
            for pat in FORBIDDEN {
                if line.contains(pat) {
                    found.push(format!("{rel}:{}: `{pat}` in {}", n + 1, line.trim()));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "paths outside the repository:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_pipeline_runs_in_a_clone_with_no_siblings() {
    let dir = common::fresh_copy("standalone");
    let siblings: Vec<_> = std::fs::read_dir(dir.parent().unwrap())
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(
        siblings,
        ["furnace"],
        "the copy must stand alone in its folder"
    );

    // `cargo run --release -- run` at small sizes, the separable conductor so that the report
    // sets furnace's fit beside the paper's
    let run = "furnace run --models ggx-conductor-separable --resolution-2d 17 --max-degree 2 \
               --quick-report --data-dir scratch/data --fits-dir scratch/fits --reports-dir scratch/reports";
    let o = common::shell(run, &dir);
    assert!(o.status.success(), "{run}\n{}", common::text(&o));
    let report = std::fs::read_to_string(dir.join("scratch/reports/README.md")).unwrap();
    assert!(
        !report.contains("No paper comparison"),
        "the report did not find the paper's data in the repository:\n{report}"
    );
    assert!(
        report.contains("Sforza & Pellacini 2022 publish"),
        "the report has no side-by-side with the paper"
    );

    // the quadrature benchmark reads the reference albedos by default
    let bench = "furnace bench tabulate --quick --orders 8 --models ggx-conductor";
    let o = common::shell(bench, &dir);
    assert!(o.status.success(), "{bench}\n{}", common::text(&o));
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}
