//! Input `furnace` refuses before it works, with a message that names the option or value at
//! fault and the fix.
//! Standard output that cannot be written is an error (exit status 1), never a crash.

mod common;

use common::{furnace, repository, scratch, stderr};
use std::path::{Path, PathBuf};
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

/// A 10 × 10 CSV table on [0, 1]² of 0.5 with `value` at row 7 (the sixth data row).
fn csv_with(d: &Path, name: &str, value: &str) -> PathBuf {
    let mut text = String::from("r,mu,E\n");
    for i in 0..10 {
        for j in 0..10 {
            let v = if i * 10 + j == 5 { value } else { "0.5" };
            text.push_str(&format!("{},{},{v}\n", i as f64 / 9.0, j as f64 / 9.0));
        }
    }
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn values_too_large_to_measure_a_fit_on_are_refused_naming_the_value() {
    let d = scratch("huge-values");
    let table = csv_with(&d, "u3.csv", "1e300");
    let fit = |table: &Path| {
        vec![
            "fit".to_string(),
            "--table".into(),
            table.display().to_string(),
            "--form".into(),
            "polynomial".into(),
            "--degree".into(),
            "2".into(),
            "--output".into(),
            "out.json".into(),
        ]
    };
    let args = fit(&table);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    refused(
        &args,
        &d,
        &[
            "u3.csv: row 7, column 'E' is 1e300, beyond the largest magnitude a fit accepts, ±1e100",
            "rescale the values",
        ],
    );
    for v in ["1e308", "-1e308"] {
        let grid = d.join("big.json");
        std::fs::write(
            &grid,
            format!(
                r#"{{"axes":[{{"name":"r","nodes":[0,0.5,1]}},{{"name":"mu","nodes":[0,0.5,1]}}],"values":[0.1,0.2,0.3,0.2,{v},0.4,0.3,0.4,0.5]}}"#
            ),
        )
        .unwrap();
        let args = fit(&grid);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(
            &args,
            &d,
            &["value 4 is", "beyond the largest magnitude", "rescale"],
        );
    }
    assert!(!d.join("out.json").exists());
    // a value at the bound is fitted, and every metric is a number
    let table = csv_with(&d, "bound.csv", "1e100");
    let args = fit(&table);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = furnace(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let json = std::fs::read_to_string(d.join("out.json")).unwrap();
    assert!(!json.to_lowercase().contains("nan"), "{json}");
}

#[test]
fn a_json_grid_naming_a_variable_twice_is_refused() {
    let d = scratch("duplicate-axes");
    std::fs::write(
        d.join("j4.json"),
        r#"{"axes":[{"name":"r","nodes":[0,0.5,1]},{"name":"r","nodes":[0,0.5,1]}],"values":[0.1,0.2,0.3,0.2,0.3,0.4,0.3,0.4,0.5]}"#,
    )
    .unwrap();
    refused(
        &[
            "fit",
            "--table",
            "j4.json",
            "--form",
            "polynomial",
            "--degree",
            "1",
            "--output",
            "j4fit.json",
        ],
        &d,
        &["j4.json: variable 'r' is named twice; give every variable its own name"],
    );
    assert!(!d.join("j4fit.json").exists());
}

#[test]
fn a_csv_table_may_start_with_a_byte_order_mark() {
    let d = scratch("bom");
    let plain = csv_with(&d, "plain.csv", "0.5");
    let text = std::fs::read_to_string(&plain).unwrap();
    std::fs::write(d.join("bom.csv"), format!("\u{feff}{text}")).unwrap();
    let o = furnace(
        &[
            "fit",
            "--table",
            "bom.csv",
            "--form",
            "polynomial",
            "--degree",
            "1",
            "--output",
            "bom.json",
        ],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let json = std::fs::read_to_string(d.join("bom.json")).unwrap();
    assert!(json.contains("\"mu\"") && !json.contains('\u{feff}'));
}

#[test]
fn a_tolerance_the_table_cache_cannot_record_is_refused() {
    let d = scratch("tolerance");
    for t in ["inf", "NaN"] {
        refused(
            &[
                "tabulate",
                "--model",
                "ggx-conductor",
                "--resolution",
                "8",
                "--tolerance",
                t,
            ],
            &d,
            &[&format!("tolerance {t} must be a positive finite number")],
        );
    }
    assert!(!d.join("data").exists());
}

#[test]
fn bench_fit_refuses_a_sweep_without_degrees() {
    refused(
        &[
            "bench",
            "fit",
            "--models",
            "ggx-conductor",
            "--max-degree",
            "0",
        ],
        &scratch("max-degree"),
        &["--max-degree 0", "give --max-degree 1 or more"],
    );
}

#[test]
fn report_refuses_a_fits_folder_that_does_not_exist() {
    let d = scratch("fits-dir");
    refused(
        &[
            "report",
            "--fits-dir",
            "nonexist",
            "--model",
            "ggx-conductor",
        ],
        &d,
        &["nonexist: no such folder; point --fits-dir at"],
    );
    assert!(!d.join("reports").exists());
}

#[test]
fn size_errors_name_the_option_that_sets_the_size() {
    let d = scratch("size-options");
    std::fs::create_dir_all(d.join("fits")).unwrap();
    let e = refused(
        &["report", "--anisotropy", "bogus"],
        &d,
        &[
            "--anisotropy 'bogus': 'bogus' is not a whole number",
            "`none`",
        ],
    );
    assert!(!e.contains("--resolution"), "{e}");
    refused(
        &[
            "report",
            "--model",
            "ggx-conductor",
            "--resolution-2d",
            "100000",
        ],
        &d,
        &["over the limit of 8.0 GiB; choose a smaller --resolution-2d"],
    );
    std::fs::copy(conductor_fit(), d.join("best-20.json")).unwrap();
    refused(
        &[
            "emit",
            "--fit",
            "best-20.json",
            "--lang",
            "lut",
            "--lut-resolution",
            "100000",
        ],
        &d,
        &["over the limit of 8.0 GiB; choose a smaller --lut-resolution"],
    );
    assert!(!d.join("data").exists() && !d.join("reports").exists());
}
