//! Every built-in GGX model against the independently computed albedos in data/reference
//! (12 significant digits; see its README for how they were made).

use furnace::bsdf::{albedo, find};
use furnace::quadrature::{QuadratureSettings, RuleCache};
use std::path::PathBuf;

const TOLERANCE: f64 = 1e-8;

fn reference(name: &str) -> Vec<Vec<f64>> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data/reference")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| v.trim().parse::<f64>().unwrap())
                .collect()
        })
        .collect()
}

fn check(
    model: &str,
    rows: &[Vec<f64>],
    point: impl Fn(&[f64]) -> Vec<f64>,
    expected: impl Fn(&[f64]) -> Vec<f64>,
) {
    let m = find(model).unwrap();
    let settings = QuadratureSettings::default();
    let cache = RuleCache::new(&settings);
    let mut worst = (0.0f64, String::new());
    for row in rows {
        let x = point(row);
        let est = albedo(m.as_ref(), &x, &settings, &cache);
        for (k, want) in expected(row).iter().enumerate() {
            let d = (est.value[k] - want).abs();
            if d > worst.0 {
                worst = (
                    d,
                    format!(
                        "{model} output {k} at {x:?}: got {} want {want}",
                        est.value[k]
                    ),
                );
            }
        }
    }
    eprintln!("{model}: max |ΔE| = {:.3e} ({})", worst.0, worst.1);
    assert!(worst.0 <= TOLERANCE, "{}", worst.1);
}

#[test]
fn conductors_match_reference() {
    let rows = reference("ref2d.csv");
    check("ggx-conductor", &rows, |r| vec![r[0], r[1]], |r| vec![r[2]]);
    check(
        "ggx-conductor-separable",
        &rows,
        |r| vec![r[0], r[1]],
        |r| vec![r[3]],
    );
    let rows3 = reference("ref3d.csv");
    check(
        "ggx-conductor",
        &rows3,
        |r| vec![r[2], r[3]],
        |r| vec![r[4]],
    );
}

#[test]
fn dielectrics_match_reference() {
    let rows = reference("ref3d.csv");
    check(
        "ggx-dielectric",
        &rows,
        |r| vec![r[0], r[2], r[3]],
        |r| vec![r[5] + r[6], r[5], r[6]],
    );
    check(
        "ggx-dielectric-inv",
        &rows,
        |r| vec![r[0], r[2], r[3]],
        |r| vec![r[7] + r[8], r[7], r[8]],
    );
}

#[test]
fn glossy_matches_reference() {
    let rows = reference("ref3d.csv");
    check(
        "ggx-glossy",
        &rows,
        |r| vec![r[0], r[2], r[3]],
        |r| vec![r[5] / r[4]],
    );
}
