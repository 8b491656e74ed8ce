//! The white furnace test on small engine tables, and `reports/` end to end on a tiny
//! configuration: files linked and present, images of the expected size, byte-identical reruns.

use furnace::bsdf::{self, Model, Transmission};
use furnace::fit::{
    fit_polynomial, fit_rational, FitData, InputTransform, Objective, PolynomialOptions,
    RationalOptions,
};
use furnace::material::builtin::{Kind, Material};
use furnace::material::furnace::{furnace_stats, furnace_values, lobe_integrals_at};
use furnace::material::kulla_conty::KullaConty;
use furnace::material::{CompensatedBsdf, Compensation};
use furnace::math::SmithForm;
use furnace::quadrature::QuadratureSettings;
use furnace::report::albedo::{FitAlbedo, TableAlbedo};
use furnace::report::inputs::TableProvider;
use furnace::report::model::{ReportOptions, Reporter};
use furnace::report::offgrid::{BudgetErrors, LutErrors, OffGridSummary, PointErrors};
use furnace::table::{self, Table, TableSpec};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn table(name: &str, transmission: Transmission, resolution: &[usize]) -> Table {
    let model = bsdf::find_variant(name, transmission).unwrap();
    let spec = TableSpec::new(model.as_ref(), resolution, QuadratureSettings::default()).unwrap();
    table::tabulate(model.as_ref(), &spec, &|_| {}).unwrap()
}

fn nodes(t: &Table) -> Vec<Vec<f64>> {
    let mut x = vec![0.0; t.spec.axes.len()];
    (0..t.cells())
        .map(|c| {
            t.spec.point(c, &mut x);
            x.clone()
        })
        .collect()
}

/// max |1 − E| of `material` compensated with `table` (and `conductor` for glossy) at the table's nodes,
/// and the same without compensation.
fn furnace_on_nodes(
    material: &dyn CompensatedBsdf,
    t: &Table,
    conductor: Option<&Table>,
) -> (f64, f64) {
    let points = nodes(t);
    let lobes = lobe_integrals_at(material, &points);
    assert!(
        lobes.iter().all(|l| l.converged),
        "{}: furnace quadrature did not converge",
        material.label()
    );
    let exact = TableAlbedo::new(t);
    let cond = conductor.map(TableAlbedo::new);
    let mut sources: Vec<&dyn furnace::material::Albedo> = vec![&exact];
    sources.extend(cond.as_ref().map(|c| c as &dyn furnace::material::Albedo));
    let comp = Compensation::With(sources);
    let with = furnace_stats(&points, &furnace_values(material, &points, &lobes, &comp));
    let none = furnace_stats(
        &points,
        &furnace_values(material, &points, &lobes, &Compensation::None),
    );
    (with.max_deviation, none.max_deviation)
}

/// The white furnace test proper: the compensated conductor with the exact table passes the
/// furnace to ≤ 1e-6 — its albedo integrated independently of the table — while the
/// uncompensated one visibly does not.
#[test]
fn conductor_with_the_exact_table_passes_the_furnace_to_1e6() {
    for (name, smith) in [
        ("ggx-conductor", SmithForm::HeightCorrelated),
        ("ggx-conductor-separable", SmithForm::Separable),
    ] {
        let t = table(name, Transmission::Energy, &[17, 17]);
        // Turquin's scale, and Kulla–Conty's lobe with the E_avg of the same bilinear E (the
        // coloured row also measures that E_avg against the engine's, so it carries the
        // table's interpolation error in μ)
        let materials: Vec<Box<dyn CompensatedBsdf>> = vec![
            Box::new(Material::new(Kind::Conductor, smith)),
            Box::new(KullaConty::white(smith)),
        ];
        for m in &materials {
            let (with, none) = furnace_on_nodes(m.as_ref(), &t, None);
            eprintln!(
                "{name}, {}: furnace max |1 − E| with the exact table {with:.2e}, without compensation {none:.3}",
                m.label()
            );
            assert!(with <= 1e-6, "{name}, {}: {with:e}", m.label());
            assert!(
                none > 0.5,
                "{name}: the uncompensated conductor loses up to 1 − E(r=1, μ=1) ≈ 0.69, got {none}"
            );
        }
    }
}

/// Every other material class passes with its exact tables too (coarse grids).
#[test]
fn every_class_passes_with_its_exact_tables() {
    let hc = SmithForm::HeightCorrelated;
    let cond = table("ggx-conductor", Transmission::Energy, &[9, 9]);
    let cases: Vec<(Material, Table, Option<&Table>)> = vec![
        (Material::new(Kind::ThinDielectric, hc), cond.clone(), None),
        (
            Material::new(Kind::Glossy, hc),
            table("ggx-glossy", Transmission::Energy, &[3, 9, 9]),
            Some(&cond),
        ),
        (
            Material::new(Kind::Dielectric, hc),
            table("ggx-dielectric", Transmission::Energy, &[3, 9, 9]),
            None,
        ),
        (
            Material::new(Kind::Dielectric, hc).leaving(),
            table("ggx-dielectric-inv", Transmission::Energy, &[3, 9, 9]),
            None,
        ),
        (
            Material::new(Kind::Dielectric, SmithForm::Separable)
                .leaving()
                .with_transmission(Transmission::Radiance),
            table(
                "ggx-dielectric-inv-separable",
                Transmission::Radiance,
                &[3, 9, 9],
            ),
            None,
        ),
        (
            Material::new(Kind::RoughDiffuse, hc),
            table("oren-nayar-fon", Transmission::Energy, &[9, 9]),
            None,
        ),
    ];
    for (m, t, c) in &cases {
        let (with, none) = furnace_on_nodes(m, t, *c);
        eprintln!(
            "{}: with exact table {with:.2e}, without {none:.3}",
            m.label()
        );
        assert!(with <= 1e-6, "{}: {with:e}", m.label());
        assert!(
            none > 0.1,
            "{}: uncompensated deviation {none} should be visible",
            m.label()
        );
    }
}

fn grid_data(t: &Table) -> FitData {
    let axes: Vec<Vec<f64>> = t.spec.axes.iter().map(|a| a.nodes()).collect();
    FitData::from_grid(
        t.spec.axes.iter().map(|a| a.name.clone()).collect(),
        &axes,
        t.output(0).to_vec(),
    )
    .unwrap()
}

/// The acceptance test, part 2: compensated with a fit, the conductor passes the furnace to within
/// that fit's reported maximum relative error ρ: at the fitted points |1 − E| = |fit − E_ss|/fit ≤
/// ρ/(1 − ρ), plus the furnace quadrature's own accuracy.
#[test]
fn conductor_with_a_fit_passes_to_within_its_relative_error() {
    let t = table("ggx-conductor", Transmission::Energy, &[17, 17]);
    let data = grid_data(&t);
    let id = [InputTransform::Identity; 2];
    let fits = vec![
        fit_rational(
            &data,
            &id,
            3,
            3,
            Objective::LeastSquares,
            &RationalOptions::default(),
        )
        .unwrap(),
        fit_polynomial(
            &data,
            &id,
            4,
            Objective::LeastSquares,
            &PolynomialOptions::default(),
        )
        .unwrap(),
    ];
    let points = nodes(&t);
    let lobes = lobe_integrals_at(
        &Material::new(Kind::Conductor, SmithForm::HeightCorrelated),
        &points,
    );
    for fit in &fits {
        let rho = fit.metrics.max_rel_error;
        let albedo = FitAlbedo::new(fit, &["r".into(), "mu".into()]).unwrap();
        let comp = Compensation::With(vec![&albedo]);
        let m = Material::new(Kind::Conductor, SmithForm::HeightCorrelated);
        let s = furnace_stats(&points, &furnace_values(&m, &points, &lobes, &comp));
        eprintln!(
            "{}: reported max rel. error {rho:.3e}, furnace max |1 − E| {:.3e}",
            fit.form.label(),
            s.max_deviation
        );
        assert!(
            s.max_deviation <= rho / (1.0 - rho) + 1e-6,
            "{}: {} > {}",
            fit.form.label(),
            s.max_deviation,
            rho / (1.0 - rho)
        );
        // and the bound is attained up to the quadrature: the furnace sees the fit's error
        assert!(
            s.max_deviation >= rho / (1.0 + rho) - 1e-6,
            "{}: {} < {}",
            fit.form.label(),
            s.max_deviation,
            rho / (1.0 + rho)
        );
    }
}

/// An in-memory table provider (tabulates on first use) that counts requests.
struct Tables {
    cache: RefCell<BTreeMap<String, Table>>,
}

impl TableProvider for Tables {
    fn table(&self, model: &dyn Model, resolution: &[usize]) -> furnace::Result<Table> {
        let key = format!("{}-{:?}", model.id().key(), resolution);
        if let Some(t) = self.cache.borrow().get(&key) {
            return Ok(t.clone());
        }
        let spec = TableSpec::new(model, resolution, QuadratureSettings::default())?;
        let t = table::tabulate(model, &spec, &|_| {})?;
        self.cache.borrow_mut().insert(key, t.clone());
        Ok(t)
    }
}

fn tiny_options(root: &Path) -> ReportOptions {
    let mut o = ReportOptions::new(root);
    o.resolution_2d = 9;
    o.resolution_3d = 5;
    o.lut_2d = 5;
    o.lut_3d = 3;
    o.furnace_luts = vec![3, 5];
    o.furnace_nodes = 9;
    o.furnace_f0_slices = 2;
    o.sphere_roughness = vec![0.3, 1.0];
    o.anisotropy = Some(furnace::report::aniso::QUICK_RESOLUTION.to_vec());
    let paper = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/paper");
    assert!(
        paper.join("coefficients").is_dir(),
        "{} not found",
        paper.display()
    );
    o.paper_dir = Some(paper);
    o
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(files_under(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Markdown link targets `](target)`.
fn links(md: &str) -> Vec<String> {
    md.split("](")
        .skip(1)
        .filter_map(|s| s.split(')').next())
        .filter(|l| !l.starts_with('#') && !l.starts_with("http"))
        .map(String::from)
        .collect()
}

fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

#[test]
fn report_links_every_file_it_writes_and_reruns_byte_identically() {
    let root = std::env::temp_dir().join(format!("furnace-report-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    // one fit for the conductor (a degree-2 rational on the 9² table), none for the others
    let cond = table("ggx-conductor-separable", Transmission::Energy, &[9, 9]);
    let fit = fit_rational(
        &grid_data(&cond),
        &[InputTransform::Identity; 2],
        2,
        2,
        Objective::LeastSquares,
        &RationalOptions::default(),
    )
    .unwrap();
    let fit_dir = root.join("fits/ggx-conductor-separable/sweep");
    std::fs::create_dir_all(&fit_dir).unwrap();
    std::fs::write(fit_dir.join("rational2.json"), fit.to_json().unwrap()).unwrap();
    std::fs::write(fit_dir.join("notes.json"), "{\"comment\": 1}").unwrap();
    // the same fit as the sweep's best within 20 coefficients, with the off-grid errors a run
    // records beside it (here: losing to the 32-per-axis LUT on max error)
    let best_dir = root.join("fits/ggx-conductor-separable");
    std::fs::write(best_dir.join("best-20.json"), fit.to_json().unwrap()).unwrap();
    let lut = |per_axis: usize, max: f64| LutErrors {
        per_axis,
        values: per_axis * per_axis,
        errors: PointErrors {
            max_abs_error: max,
            mae: max / 10.0,
            max_abs_error_at: vec![0.5, 0.5],
        },
    };
    let off_grid = OffGridSummary {
        what: "errors at the check points".into(),
        tool: "furnace".into(),
        tool_version: furnace::VERSION.into(),
        model: "ggx-conductor-separable".into(),
        check_set: "100 off-grid points".into(),
        best: vec![BudgetErrors {
            budget: 20,
            file: "best-20.json".into(),
            form: "rational of degree 2/2".into(),
            n_coefficients: 13,
            max_abs_error: 2e-2,
            mae: 1e-4,
        }],
        luts: vec![lut(16, 3e-2), lut(32, 1e-2), lut(64, 5e-3)],
    };
    off_grid.write(&best_dir).unwrap();
    // the anisotropic conductor's budget fits, as `furnace run` writes them
    let mut job = furnace::pipeline::Job::default_set(&root);
    job.quick_report();
    let aniso = furnace::pipeline::aniso::fits_or_reuse(
        &job,
        &furnace::report::aniso::QUICK_RESOLUTION,
        &furnace::progress::Quiet,
    )
    .unwrap();
    assert!(!aniso.step.reused && aniso.step.best.iter().all(|b| b.1.is_some()));
    std::fs::create_dir_all(root.join("reports/bench")).unwrap();
    std::fs::write(root.join("reports/bench/eval-cost.csv"), "# title: Evaluation cost\n# x: ns per call (log)\n# y: max error (log)\nseries,ns,err\nfit,2.5,1e-3\nfit,4,2e-4\nLUT,1.5,3e-3\n").unwrap();

    let tables = Tables {
        cache: RefCell::new(BTreeMap::new()),
    };
    let quiet = |_: &str| {};
    let models = vec![
        bsdf::lookup("ggx-conductor-separable").unwrap(),
        bsdf::lookup("oren-nayar-fon").unwrap(),
    ];
    let run = || {
        let reporter = Reporter::new(tiny_options(&root), &tables, &quiet);
        reporter.generate(Some(&models)).unwrap()
    };
    let outcome = run();
    let reports = root.join("reports");
    let readme = std::fs::read_to_string(&outcome.readme).unwrap();

    // every link resolves, and every figure is linked
    let linked = links(&readme);
    for l in &linked {
        assert!(
            reports.join(l).is_file(),
            "README links {l}, which does not exist"
        );
    }
    let written = files_under(&reports);
    for f in &written {
        let rel = f
            .strip_prefix(&reports)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if rel.ends_with(".png") || rel.ends_with(".svg") {
            assert!(
                linked.contains(&rel),
                "{rel} is written but not linked from README.md"
            );
        }
        if rel.ends_with(".md") || rel.ends_with(".json") || rel.ends_with(".svg") {
            let text = std::fs::read_to_string(f).unwrap();
            assert!(
                !text.contains("NaN") && !text.contains("\"nan\"") && !text.contains("null"),
                "{rel} contains a non-finite number"
            );
        }
    }
    // what it cannot compute yet it says, with the command to run
    assert!(
        readme.contains("run `furnace fit --model oren-nayar-fon --sweep` first"),
        "missing-fit hint"
    );
    assert!(
        readme.contains("skipped `sweep/notes.json`"),
        "unreadable fit files are listed"
    );
    assert!(
        readme.contains("### ggx-conductor-separable") && readme.contains("### oren-nayar-fon")
    );
    assert!(readme.contains("Not generated yet: run `furnace report --model ggx-glossy`"));
    assert!(readme.contains("rational 2/2"), "the fit is in the tables");
    // expected figures with the expected pixel sizes
    let expect = [
        (
            "ggx-conductor-separable/error-vs-coefficients.png",
            (1300, 560),
        ),
        ("ggx-conductor-separable/heatmap-abs.png", (1000, 580)),
        ("ggx-conductor-separable/off-grid.png", (1300, 560)),
        ("ggx-conductor-separable/slices.png", (1600, 620)),
        (
            "ggx-conductor-separable/furnace-conductor-separable.png",
            (300 + 2 * 132 + 160, 84 + 4 * 132 + 46),
        ),
        (
            "oren-nayar-fon/furnace-rough-diffuse.png",
            (300 + 2 * 132 + 160, 84 + 3 * 132 + 46),
        ),
        ("benchmarks/eval-cost.png", (900, 600)),
        ("anisotropy/shortcuts.png", (1500, 520)),
    ];
    for (f, size) in expect {
        let bytes = std::fs::read(reports.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(png_size(&bytes), size, "{f}");
    }
    for svg in written
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "svg"))
    {
        let text = std::fs::read_to_string(svg).unwrap();
        assert!(
            text.starts_with("<svg") && text.trim_end().ends_with("</svg>"),
            "{}",
            svg.display()
        );
    }
    // the summary row of the conductor carries the fit's furnace number
    let s = &outcome.regenerated[0];
    let furnace_fit = s.furnace[0]
        .variants
        .iter()
        .find(|v| v.name == "furnace fit")
        .unwrap();
    assert!(furnace_fit.stats.as_ref().unwrap().max_deviation > 0.0);
    // the furnace test runs with every LUT size and every budget
    let names: Vec<&str> = s.furnace[0]
        .variants
        .iter()
        .map(|v| v.name.as_str())
        .collect();
    for n in ["LUT 3×3 (bilinear)", "LUT 5×5 (bilinear)", "best-20"] {
        assert!(names.contains(&n), "{n} missing from {names:?}");
    }
    let best20 = s.furnace[0].variants.iter().find(|v| v.name == "best-20");
    assert_eq!(
        best20
            .and_then(|v| v.stats.as_ref())
            .map(|s| s.max_deviation),
        furnace_fit.stats.as_ref().map(|s| s.max_deviation),
        "best-20.json is the chosen fit"
    );
    // the anisotropic conductor's section: the exact table passes the furnace test, every
    // shortcut is off (aniso up to 0.95 on the 5x3x5x3 table), the uncompensated lobe loses energy
    assert!(readme.contains("## Anisotropic conductor: the isotropic shortcuts"));
    let cell = |row: &str| -> f64 {
        let line = readme
            .lines()
            .find(|l| l.starts_with(row))
            .unwrap_or_else(|| panic!("no row {row}"));
        line.split('|').nth(2).unwrap().trim().parse().unwrap()
    };
    assert!(cell("| exact table 5x3x5x3 |") < 1e-6);
    assert!(cell("| none |") > 0.3);
    for s in ["geometric mean", "projected", "larger α"] {
        assert!(cell(&format!("| isotropic, {s} |")) > 0.1, "{s}");
    }
    assert!(cell("| geometric mean √(α_t α_b) |") > 0.1);
    // the section's table as a LUT at the check points, beside the fits' errors there
    assert!(readme.contains(
        " check points the table above as a LUT (multilinear, 225 values) errs by up to "
    ));
    // furnace's fits under both budgets, read from their files, and each a far better
    // compensation than none
    assert!(
        readme.contains("furnace's fits: the best fits of the degree sweep `furnace run` makes")
    );
    for budget in [20, 40, 80, 160] {
        assert!(
            readme.contains(&format!(
                "| {budget} | `fits/ggx-conductor-aniso/best-{budget}.json` |"
            )),
            "{budget}"
        );
        let fit = cell(&format!("| furnace fit ≤ {budget} ("));
        assert!(
            fit.is_finite() && fit < 0.5 * cell("| none |"),
            "{budget}: {fit}"
        );
    }
    // the off-grid table sets each budget beside the LUTs, the loss in bold
    assert!(readme.contains("## Off-grid errors: fits against LUTs"));
    assert!(
        readme.contains("| **2.00e-2 / 1.00e-4 (13)** |")
            && readme.contains("| 1.00e-2 / 1.00e-3 (1024) |"),
        "off-grid summary row"
    );
    assert!(
        readme.contains("| LUT 3 | LUT 5 |"),
        "furnace columns per LUT size"
    );

    // same inputs → same bytes
    let before: Vec<(PathBuf, Vec<u8>)> = written
        .iter()
        .map(|p| (p.clone(), std::fs::read(p).unwrap()))
        .collect();
    run();
    let after = files_under(&reports);
    assert_eq!(after, written, "the rerun wrote a different set of files");
    for (p, bytes) in before {
        assert!(
            std::fs::read(&p).unwrap() == bytes,
            "{} differs on rerun",
            p.display()
        );
    }
    // removing the fit removes its figures (no stale files) and the README says so
    std::fs::remove_dir_all(root.join("fits")).unwrap();
    let reporter = Reporter::new(tiny_options(&root), &tables, &quiet);
    reporter.generate(Some(&models[..1])).unwrap();
    assert!(
        !reports
            .join("ggx-conductor-separable/heatmap-abs.png")
            .exists(),
        "stale heat map kept"
    );
    let _ = std::fs::remove_dir_all(&root);
}
