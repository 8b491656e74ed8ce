//! `furnace run` end to end on tiny grids: `furnace run` tabulates, fits, emits and
//! reports; a re-run reuses the sweeps and report sections and gives the same bytes; nothing
//! under fits/, reports/ or data/lut/ holds a wall time or an absolute path; the conductor
//! compensated with the fit `run` chose passes the white furnace test within that fit's relative
//! error; unwritable outputs give an error naming the path.

use furnace::fit::job::FitRecord;
use furnace::material::builtin::{Kind, Material};
use furnace::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at};
use furnace::material::Compensation;
use furnace::math::SmithForm;
use furnace::report::albedo::FitAlbedo;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn furnace(args: &[&str], dir: &Path, threads: Option<&str>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_furnace"));
    c.args(args)
        .current_dir(dir)
        .env_remove("FURNACE_PAPER_DATA");
    if let Some(t) = threads {
        c.env("RAYON_NUM_THREADS", t);
    }
    c.output().expect("runs")
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("furnace-run-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `furnace run` on two models, 17² tables, degrees ≤ 2, the report on tiny grids.
const RUN: &[&str] = &[
    "run",
    "--models",
    "ggx-conductor,oren-nayar-fon",
    "--resolution-2d",
    "17",
    "--max-degree",
    "2",
    "--quick-report",
];

/// Every file under the committed output folders, with its bytes.
fn outputs(root: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(
                    p.strip_prefix(root).unwrap().to_string_lossy().into_owned(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    let mut out = BTreeMap::new();
    for d in ["fits", "reports", "data/lut"] {
        walk(root, &root.join(d), &mut out);
    }
    out
}

fn assert_same(a: &BTreeMap<String, Vec<u8>>, b: &BTreeMap<String, Vec<u8>>, what: &str) {
    let names = |m: &BTreeMap<String, Vec<u8>>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(a), names(b), "{what}: a different set of files");
    for (k, v) in a {
        assert!(b[k] == *v, "{what}: {k} differs");
    }
}

#[test]
fn run_end_to_end_is_reproducible_and_resumes() {
    let d = scratch("e2e");
    let o = furnace(RUN, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    for want in [
        "[1/4] tables",
        "[2/4] fits",
        "[3/4] emit",
        "[4/4] report",
        "best-8",
        "best-20",
        "best-160",
        "LUT-32",
        "furnace |1−E|",
    ] {
        assert!(out.contains(want), "missing '{want}':\n{out}");
    }
    let summary_line = |name: &str| {
        out.lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no summary row for {name}:\n{out}"))
            .to_string()
    };
    assert!(
        summary_line("ggx-conductor ").contains("17x17")
            && summary_line("ggx-conductor ").contains("fitted")
    );
    for f in [
        "fits/ggx-conductor/sweep.json",
        "fits/ggx-conductor/sweep.csv",
        "fits/ggx-conductor/best-20.json",
        "fits/ggx-conductor/best-40.json",
        "fits/ggx-conductor/sweep-inputs.json",
        "fits/ggx-conductor/best-20.rs",
        "fits/ggx-conductor/best-40.wgsl",
        "fits/ggx-conductor/best-40.glsl",
        "fits/oren-nayar-fon/best-20.json",
        "fits/oren-nayar-fon/best-8.json",
        "fits/oren-nayar-fon/best-160.rs",
        "fits/ggx-conductor/off-grid.json",
        "data/lut/ggx-conductor/32x32.exr",
        "data/lut/oren-nayar-fon/32x32.f16",
        "reports/README.md",
        "reports/ggx-conductor/section.md",
        "reports/ggx-conductor/furnace-conductor.png",
        "reports/oren-nayar-fon/summary.json",
    ] {
        assert!(d.join(f).is_file(), "{f} missing:\n{out}");
    }
    // the anisotropic fits come only when their model is named
    assert!(!d.join("fits/ggx-conductor-aniso").exists());
    // the report reads what `run` wrote: the sweep's fits and the chosen best file
    let readme = std::fs::read_to_string(d.join("reports/README.md")).unwrap();
    assert!(
        readme.contains("`best-20.json`"),
        "the chosen fit is the sweep's best ≤ 20"
    );
    assert!(
        readme.contains("sweep.json#"),
        "the sweep's fits are listed"
    );
    assert!(
        !readme.contains("skipped `"),
        "every fit file was readable:\n{readme}"
    );
    // the chosen fit links its table, so the emitted header measures the f32 code at its nodes
    let best: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(d.join("fits/ggx-conductor/best-20.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        best["table"]["spec"]["model"], "ggx-conductor",
        "{}",
        best["table"]
    );
    let rs = std::fs::read_to_string(d.join("fits/ggx-conductor/best-20.rs")).unwrap();
    assert!(
        rs.contains("Error at the 289 nodes of its table") && !rs.contains("not at hand"),
        "{rs}"
    );

    // nothing committed holds a wall time or where it was made
    let first = outputs(&d);
    let root = d.to_string_lossy().into_owned();
    for (name, bytes) in &first {
        let s = String::from_utf8_lossy(bytes);
        assert!(
            !s.contains("fit_seconds") && !s.contains("seconds\""),
            "{name} holds a wall time"
        );
        assert!(!s.contains(&root), "{name} holds the absolute path {root}");
    }
    assert!(
        d.join("data/timing/ggx-conductor/sweep-timing.json")
            .is_file(),
        "wall times go to data/timing/"
    );

    // re-run: tables cached, sweeps and sections reused, same bytes
    let o = furnace(RUN, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(
        out.contains("reused (same table values and options)"),
        "{out}"
    );
    assert!(
        out.contains("0 regenerated, 2 unchanged inputs: kept"),
        "{out}"
    );
    let emitted = out
        .lines()
        .find(|l| l.contains("  emit: "))
        .expect("an emit line");
    let total = emitted
        .split(" of ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .expect("kept N of M fits");
    assert!(
        total != "0" && emitted.contains(&format!("({total} of {total} fits kept")),
        "{emitted}"
    );
    assert_same(&first, &outputs(&d), "cached re-run");

    // a damaged emitted file is not kept: that fit is emitted again and the file restored
    std::fs::write(d.join("fits/ggx-conductor/best-20.rs"), "damaged").unwrap();
    let o = furnace(RUN, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    let again = text(&o);
    assert!(
        !again.contains(&format!("({total} of {total} fits kept")),
        "{again}"
    );
    assert_same(
        &first,
        &outputs(&d),
        "after repairing a damaged emitted file",
    );

    // refit and regenerate everything on one thread: still the same bytes
    let refit: Vec<&str> = RUN.iter().copied().chain(["--refit"]).collect();
    let o = furnace(&refit, &d, Some("1"));
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("fitted"));
    let _ = std::fs::remove_dir_all(d.join("reports"));
    let o = furnace(RUN, &d, Some("1"));
    assert!(o.status.success(), "{}", text(&o));
    assert_same(&first, &outputs(&d), "refit on one thread");

    // a damaged fit file is not reused: the sweep is redone and the file restored
    std::fs::write(d.join("fits/ggx-conductor/best-20.json"), "{}").unwrap();
    let o = furnace(RUN, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o)
            .lines()
            .any(|l| l.contains("ggx-conductor") && l.contains("fitted:")),
        "{}",
        text(&o)
    );
    assert_same(&first, &outputs(&d), "after repairing a damaged fit");

    // the white furnace test with the fit `run` chose: the compensated conductor passes the
    // furnace within that fit's reported relative error ρ (|1 − E| = |fit − E_ss|/fit ≤ ρ/(1 − ρ)
    // at the table's nodes, plus the furnace quadrature's accuracy)
    let rec = FitRecord::from_json(
        &std::fs::read_to_string(d.join("fits/ggx-conductor/best-20.json")).unwrap(),
    )
    .unwrap();
    let rho = rec.fit.metrics.max_rel_error;
    assert!(rho > 0.0 && rho < 0.5, "ρ = {rho}");
    let nodes: Vec<Vec<f64>> = (0..17)
        .flat_map(|i| (0..17).map(move |j| vec![i as f64 / 16.0, j as f64 / 16.0]))
        .collect();
    let m = Material::new(Kind::Conductor, SmithForm::HeightCorrelated);
    let lobes = lobe_integrals_at(&m, &nodes);
    let albedo = FitAlbedo::new(&rec.fit, &["r".into(), "mu".into()]).unwrap();
    let s = furnace_stats(
        &nodes,
        &furnace_values(&m, &nodes, &lobes, &Compensation::With(vec![&albedo])),
    );
    eprintln!(
        "best-20: ρ = {rho:.3e}, furnace max |1 − E| = {:.3e}",
        s.max_deviation
    );
    assert!(
        s.max_deviation <= rho / (1.0 - rho) + 1e-6,
        "{} > {}",
        s.max_deviation,
        rho / (1.0 - rho)
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The same acceptance test on the committed default fit (`fits/ggx-conductor/best-20.json`, made
/// by `furnace run` from the 1024² table): at every 32nd node of its table (ρ is its max relative
/// error over all nodes, so the bound holds at any of them).
#[test]
fn the_committed_default_conductor_fit_passes_within_its_relative_error() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fits/ggx-conductor/best-20.json");
    let Ok(text) = std::fs::read_to_string(&path) else {
        eprintln!(
            "{} not found (run `furnace run`); nothing to check",
            path.display()
        );
        return;
    };
    let rec = FitRecord::from_json(&text).unwrap();
    let n = rec.source.resolution.as_ref().map_or(1024, |r| r[0]);
    let stride = ((n - 1) / 32).max(1);
    let axis: Vec<f64> = (0..n)
        .step_by(stride)
        .map(|i| i as f64 / (n - 1) as f64)
        .collect();
    let nodes: Vec<Vec<f64>> = axis
        .iter()
        .flat_map(|&r| axis.iter().map(move |&mu| vec![r, mu]))
        .collect();
    let m = Material::new(Kind::Conductor, SmithForm::HeightCorrelated);
    let lobes = lobe_integrals_at(&m, &nodes);
    let albedo = FitAlbedo::new(&rec.fit, &["r".into(), "mu".into()]).unwrap();
    let s = furnace_stats(
        &nodes,
        &furnace_values(&m, &nodes, &lobes, &Compensation::With(vec![&albedo])),
    );
    let rho = rec.fit.metrics.max_rel_error;
    eprintln!(
        "committed best-20 ({}): ρ = {rho:.3e}, furnace max |1 − E| = {:.3e} at {:?} ({} nodes)",
        rec.fit.form.label(),
        s.max_deviation,
        s.at,
        nodes.len()
    );
    assert!(
        s.max_deviation <= rho / (1.0 - rho) + 1e-6,
        "{} > {}",
        s.max_deviation,
        rho / (1.0 - rho)
    );
}

#[test]
fn unwritable_outputs_name_the_path() {
    let d = scratch("unwritable");
    // a file where the report folder should be: no folder can be made there (this also fails
    // as root, unlike a permission bit), which the run finds before computing anything
    std::fs::write(d.join("reports"), "not a folder").unwrap();
    let o = furnace(
        &[
            "run",
            "--models",
            "oren-nayar-fon",
            "--resolution-2d",
            "9",
            "--max-degree",
            "1",
            "--quick-report",
        ],
        &d,
        None,
    );
    assert!(!o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("error: ") && err.contains("reports") && err.contains("--reports-dir"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    // found before any work: nothing was tabulated or fitted
    assert!(!d.join("fits/oren-nayar-fon").exists());
    assert!(!d.join("data/oren-nayar-fon").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn unknown_models_are_refused_with_the_choices() {
    let d = scratch("unknown");
    let o = furnace(&["run", "--models", "ggx-metal"], &d, None);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("'ggx-metal' is not in the default set") && err.contains("eon"),
        "{err}"
    );
    assert!(!d.join("data").exists());
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn run_writes_the_anisotropic_budget_fits_with_their_code_and_reuses_them() {
    let d = scratch("aniso");
    let args = &["run", "--models", "ggx-conductor-aniso", "--quick-report"];
    // (the sweep's best files for every budget, its sweep.{json,csv} and sweep-inputs.json)
    let o = furnace(args, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    let out = text(&o);
    assert!(
        out.contains("ggx-conductor-aniso") && out.contains("4-D fits fitted: best-20 max"),
        "{out}"
    );
    let dir = d.join("fits/ggx-conductor-aniso");
    for budget in [80, 160] {
        let rec: FitRecord = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("best-{budget}.json"))).unwrap(),
        )
        .unwrap();
        // certified, within its budget, fitted on the 5x3x5x3 table's nodes and twice as many
        // exact training points, measured at the nodes and at the off-grid check points
        assert!(rec.usable, "{}", rec.verdict);
        assert!(rec.fit.n_coefficients <= budget);
        assert_eq!(rec.fitted_on.points, 3 * 225, "{}", rec.fitted_on.selection);
        assert_eq!(rec.fit.metrics.n_points, 5 * 3 * 5 * 3);
        let off = rec.off_grid.as_ref().expect("off-grid errors");
        assert!(off.metrics.n_points > 10_000 && off.metrics.max_abs_error < 0.2);
        for ext in ["rs", "wgsl", "glsl", "hlsl", "h"] {
            let code = std::fs::read_to_string(dir.join(format!("best-{budget}.{ext}"))).unwrap();
            assert!(
                code.contains("ggx_conductor_aniso_albedo"),
                "best-{budget}.{ext}"
            );
            // the header states the error between the nodes, not only at them
            assert!(
                code.contains(&format!(
                    "at {} off-grid check points",
                    off.metrics.n_points
                )),
                "best-{budget}.{ext}"
            );
        }
    }
    let readme = std::fs::read_to_string(d.join("reports/README.md")).unwrap();
    assert!(readme.contains("| 160 | `fits/ggx-conductor-aniso/best-160.json` |"));
    // a re-run keeps the fits, their code and the report's section, byte for byte
    let first = outputs(&d);
    let o = furnace(args, &d, None);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("4-D fits reused: best-20"),
        "{}",
        text(&o)
    );
    assert_same(&first, &outputs(&d), "re-run");
    // an edited fit file is refitted, and the section follows
    let best = dir.join("best-80.json");
    let bytes = std::fs::read(&best).unwrap();
    std::fs::write(&best, [&bytes[..], b" "].concat()).unwrap();
    let o = furnace(args, &d, None);
    assert!(text(&o).contains("4-D fits fitted"), "{}", text(&o));
    assert_same(&first, &outputs(&d), "refit");
    let _ = std::fs::remove_dir_all(&d);
}
