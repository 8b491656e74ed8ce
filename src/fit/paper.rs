//! The published degree-3 rationals of Sforza & Pellacini 2022 (Appendix A, Table 1) and their
//! 32-point tables, as shipped in the paper's repository (dsforza96/energy-preservation,
//! `resources/`), loaded into furnace's types so they can be evaluated against any table.
//!
//! Coefficient files hold one line: the numerator (10 monomials in 2D, 20 in 3D) then the
//! denominator without its constant 1 (9 or 19), in scikit-learn `PolynomialFeatures(3)` order
//! — exactly [`super::basis::exponents`]. Paper typos (eqs. 24–25) do not matter here: the last
//! 2D denominator term is μ³ and the 3D term a14 is F0·r·μ, as the order implies.

use std::path::Path;

use super::basis::{exponents, Polynomial};
use super::data::{FitData, InputTransform};
use super::error::{FitError, Result};
use super::poles::CertifyOptions;
use super::result::{Approximant, FitResult, Form, Objective};

/// Smallest r of the paper's tables (its repository clamps r to ≥ 0.035; paper-repo-data README).
pub const PAPER_R_MIN: f64 = 0.035;
/// Smallest μ of the paper's tables (clamped to ≥ 0.02).
pub const PAPER_MU_MIN: f64 = 0.02;
/// Largest μ of the paper's dielectric tables (clamped to ≤ 0.98).
pub const PAPER_MU_MAX_DIELECTRIC: f64 = 0.98;

/// The paper's box inside a domain: r ≥ [`PAPER_R_MIN`], μ ≥ [`PAPER_MU_MIN`] (and for a
/// dielectric model μ ≤ [`PAPER_MU_MAX_DIELECTRIC`]), other variables as they are. None if the
/// data has no variables `r` and `mu` or the box misses the domain.
pub fn paper_box_in(
    names: &[String],
    domain: &[(f64, f64)],
    model: Option<&str>,
) -> Option<Vec<(f64, f64)>> {
    let find = |n: &str| names.iter().position(|x| x.eq_ignore_ascii_case(n));
    let (r, mu) = (find("r")?, find("mu")?);
    let mut b = domain.to_vec();
    b[r].0 = b[r].0.max(PAPER_R_MIN);
    b[mu].0 = b[mu].0.max(PAPER_MU_MIN);
    if model.is_some_and(|m| m.contains("dielectric")) {
        b[mu].1 = b[mu].1.min(PAPER_MU_MAX_DIELECTRIC);
    }
    b.iter().all(|(lo, hi)| lo <= hi).then_some(b)
}

/// Points per axis of the paper's tables (`linspace(0, 1, 32)`).
pub const PAPER_TABLE_SIZE: usize = 32;
/// Dielectric F0 range of the paper: η from 1 to 3, i.e. F0 from 0.0125 to 0.25 (§3.5).
pub const DIELECTRIC_F0_MIN: f64 = 0.0125;
pub const DIELECTRIC_F0_MAX: f64 = 0.25;

/// Which of the paper's fits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PaperModel {
    /// E(r, μ), eq. 24.
    Conductors,
    /// E(F0, r, μ), x = F0, eq. 25.
    Glossy,
    /// E(F0, r, μ) entering the dielectric, x = normalised F0.
    Dielectrics,
    /// The same leaving (1/η).
    DielectricsInvEta,
}

impl PaperModel {
    /// From a file stem: conductors, glossy, dielectrics, dielectrics_inv_eta (the `_r` / `_t`
    /// tables map to their dielectric model).
    pub fn from_name(stem: &str) -> Option<PaperModel> {
        match stem {
            "conductors" => Some(PaperModel::Conductors),
            "glossy" => Some(PaperModel::Glossy),
            "dielectrics" | "dielectrics_r" | "dielectrics_t" => Some(PaperModel::Dielectrics),
            "dielectrics_inv_eta" | "dielectrics_inv_eta_r" | "dielectrics_inv_eta_t" => {
                Some(PaperModel::DielectricsInvEta)
            }
            _ => None,
        }
    }

    pub fn dim(self) -> usize {
        if self == PaperModel::Conductors {
            2
        } else {
            3
        }
    }

    pub fn variables(self) -> Vec<String> {
        let v: &[&str] = if self.dim() == 2 {
            &["r", "mu"]
        } else {
            &["F0", "r", "mu"]
        };
        v.iter().map(|s| s.to_string()).collect()
    }

    /// x = (clamp(F0, 0.0125, 0.25) − 0.0125)/0.2375 for dielectrics (Appendix A), else identity.
    pub fn transforms(self) -> Vec<InputTransform> {
        match self {
            PaperModel::Conductors => vec![InputTransform::Identity; 2],
            PaperModel::Glossy => vec![InputTransform::Identity; 3],
            PaperModel::Dielectrics | PaperModel::DielectricsInvEta => vec![
                InputTransform::ClampNormalize {
                    lo: DIELECTRIC_F0_MIN,
                    hi: DIELECTRIC_F0_MAX,
                },
                InputTransform::Identity,
                InputTransform::Identity,
            ],
        }
    }

    pub fn domain(self) -> Vec<(f64, f64)> {
        match self {
            PaperModel::Conductors => vec![(0.0, 1.0); 2],
            PaperModel::Glossy => vec![(0.0, 1.0); 3],
            PaperModel::Dielectrics | PaperModel::DielectricsInvEta => vec![
                (DIELECTRIC_F0_MIN, DIELECTRIC_F0_MAX),
                (0.0, 1.0),
                (0.0, 1.0),
            ],
        }
    }

    /// F0 of slice k of a 3D table.
    pub fn f0_of_slice(self, k: usize) -> f64 {
        let t = k as f64 / (PAPER_TABLE_SIZE - 1) as f64;
        match self {
            // min: rounding must not step past the domain end
            PaperModel::Dielectrics | PaperModel::DielectricsInvEta => (DIELECTRIC_F0_MIN
                + t * (DIELECTRIC_F0_MAX - DIELECTRIC_F0_MIN))
                .min(DIELECTRIC_F0_MAX),
            _ => t,
        }
    }
}

fn read_numbers(path: &Path) -> Result<Vec<Vec<f64>>> {
    let text = std::fs::read_to_string(path).map_err(|e| FitError::File {
        path: path.into(),
        message: format!("cannot read: {e}"),
    })?;
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(ln, l)| {
            l.split(',')
                .enumerate()
                .map(|(col, s)| {
                    s.trim().parse::<f64>().map_err(|_| FitError::File {
                        path: path.into(),
                        message: format!(
                            "line {}, field {}: '{}' is not a number",
                            ln + 1,
                            col + 1,
                            s.trim()
                        ),
                    })
                })
                .collect()
        })
        .collect()
}

/// Loads a published coefficient file into an [`Approximant`].
pub fn load_coefficients(path: &Path, model: PaperModel) -> Result<Approximant> {
    let rows = read_numbers(path)?;
    let d = model.dim();
    let exps = exponents(d, 3);
    let n = exps.len();
    let want = 2 * n - 1;
    let [c] = rows.as_slice() else {
        return Err(FitError::File {
            path: path.into(),
            message: format!(
                "expected one line of {want} coefficients, found {} lines",
                rows.len()
            ),
        });
    };
    if c.len() != want {
        return Err(FitError::File {
            path: path.into(),
            message: format!("expected {want} coefficients ({n} numerator + {} denominator) for {model:?}, found {}; is this the right model?", n - 1, c.len()),
        });
    }
    let mut den = vec![1.0];
    den.extend_from_slice(&c[n..]);
    let a = Approximant {
        variables: model.variables(),
        transforms: model.transforms(),
        domain: model.domain(),
        numerator: Polynomial {
            exponents: exps.clone(),
            coefficients: c[..n].to_vec(),
        },
        denominator: Some(Polynomial {
            exponents: exps,
            coefficients: den,
        }),
        factor: None,
        terms: Vec::new(),
    };
    a.validate()?;
    Ok(a)
}

/// Loads one of the paper's 32-point tables with the *unclamped* grid coordinates the paper
/// fitted with (r = i/31, μ = j/31, F0 per [`PaperModel::f0_of_slice`]), although the values
/// were computed at r ≥ 0.035 and μ ≥ 0.02.
pub fn load_table(path: &Path, model: PaperModel) -> Result<FitData> {
    let rows = read_numbers(path)?;
    let s = PAPER_TABLE_SIZE;
    let want_rows = if model.dim() == 2 { s } else { s * s };
    if rows.len() != want_rows || rows.iter().any(|r| r.len() != s) {
        return Err(FitError::File {
            path: path.into(),
            message: format!("expected {want_rows} rows of {s} values for {model:?}, found {} rows; is this the right model?", rows.len()),
        });
    }
    let axis: Vec<f64> = (0..s).map(|i| i as f64 / (s - 1) as f64).collect();
    let values: Vec<f64> = rows.into_iter().flatten().collect();
    let mut data = if model.dim() == 2 {
        FitData::from_grid(model.variables(), &[axis.clone(), axis], values)?
    } else {
        let f0: Vec<f64> = (0..s).map(|k| model.f0_of_slice(k)).collect();
        FitData::from_grid(model.variables(), &[f0, axis.clone(), axis], values)?
    };
    data.domain = model.domain();
    data.validate()?;
    Ok(data)
}

/// The published fit measured on `table` (metrics, pole verdict; no solver report).
pub fn published_fit(coefficients: &Path, model: PaperModel, table: &FitData) -> Result<FitResult> {
    let a = load_coefficients(coefficients, model)?;
    FitResult::assess(
        Form::Rational {
            numerator_degree: 3,
            denominator_degree: 3,
        },
        a,
        table,
        Objective::LeastSquares,
        None,
        &CertifyOptions::default(),
    )
}
