//! Input `furnace` refuses before it works, with a message that names the option or value at
//! fault and the fix.
//! Standard output that cannot be written is an error (exit status 1), never a crash.

mod common;

use common::{furnace, repository, scratch, stderr};
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// The committed 20-coefficient conductor fit.
fn conductor_fit() -> String {
    repository()
        .join("fits/ggx-conductor/best-20.json")
        .display()
        .to_string()
}

/// Runs `furnace` and checks that it failed with status 1 (not a usage error, not a panic)
/// and that its message contains every one of `want`; returns the message.
fn refused(args: &[&str], dir: &Path, want: &[&str]) -> String {
    let o = furnace(args, dir);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
    assert!(!e.contains("panicked"), "{args:?}: {e}");
    for w in want {
        assert!(e.contains(w), "{args:?}: no '{w}' in: {e}");
    }
    e
}

#[test]
fn point_counts_above_the_memory_limit_are_refused_before_anything_is_allocated() {
    let d = scratch("points");
    let fit = conductor_fit();
    let max = furnace::emit::stress::MAX_POINTS.to_string();
    for n in ["18446744073709551615", "1000000000000"] {
        refused(
            &["stress", "--fit", &fit, "--points", n],
            &d,
            &[
                &format!("--points {n} is above the limit of {max} random points"),
                "8.0 GiB",
            ],
        );
        refused(
            &[
                "bench", "eval", "--fit", &fit, "--points", n, "--passes", "1",
            ],
            &d,
            &[&format!("--points {n} is above the limit of {max}")],
        );
        // checked before the scene's tables are computed
        refused(
            &[
                "run",
                "--scene",
                &repository()
                    .join("examples/scene.json")
                    .display()
                    .to_string(),
                "--data-dir",
                "data",
                "--fits-dir",
                "x",
                "--stress-points",
                n,
            ],
            &d,
            &[&format!("--stress-points {n} is above the limit of {max}")],
        );
    }
    assert!(
        !d.join("data").exists() && !d.join("x").exists(),
        "nothing is computed"
    );
}

/// Runs `furnace` in `dir` with standard output on `/dev/full`.
fn to_full_disk(args: &[&str], dir: &Path) -> Output {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    Command::new(env!("CARGO_BIN_EXE_furnace"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::from(full))
        .output()
        .expect("the furnace binary runs")
}

#[test]
fn a_failed_write_to_standard_output_is_an_error_with_status_1() {
    if !Path::new("/dev/full").exists() {
        return;
    }
    let d = scratch("stdout-full");
    let fit = conductor_fit();
    let runs: [&[&str]; 3] = [
        &["models"],
        &["stress", "--fit", &fit, "--points", "1000"],
        &[
            "bench",
            "fit",
            "--models",
            "ggx-conductor",
            "--resolution-2d",
            "16",
            "--max-degree",
            "1",
        ],
    ];
    for args in runs {
        let o = to_full_disk(args, &d);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(
            e.contains("error: I/O error on standard output") && !e.contains("panicked"),
            "{args:?}: {e}"
        );
    }
}
