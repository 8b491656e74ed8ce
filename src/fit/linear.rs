//! Linear least squares for tall systems without storing them: tall-skinny QR (TSQR,
//! Demmel, Grigori, Hoemmen & Langou 2012). Rows are generated in fixed-size chunks, each chunk
//! is reduced to its R factor with nalgebra's Householder QR, and the R factors are combined in
//! a fixed binary tree — so the result is bit-for-bit the same whatever the thread count. The
//! final small triangle is solved by SVD after column equilibration, which also yields the
//! condition number used to refuse (near-)singular systems.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::error::{FitError, Result};

/// Rows per chunk: large enough to amortise the per-chunk QR, small enough to stay in cache.
pub const CHUNK_ROWS: usize = 4096;

/// Largest scaled condition number accepted (≈ 1/(10⁴·ε)); beyond it the solution's leading
/// digits are noise and the user should lower the degree.
pub const MAX_CONDITION: f64 = 1e12;

/// A tall linear system A x ≈ b whose rows are produced on demand.
pub(crate) trait LinearRows: Sync {
    fn n_rows(&self) -> usize;
    fn n_cols(&self) -> usize;
    /// Fills rows `rows` of A (column-major, `rows.len()` × `n_cols`) and of b.
    fn fill(&self, rows: Range<usize>, a: &mut [f64], b: &mut [f64]);
}

#[derive(Clone, Debug)]
pub(crate) struct LstsqSolution {
    pub x: Vec<f64>,
    /// Scaled condition number σ_max/σ_min of A after column equilibration.
    pub condition: f64,
    /// ‖A x − b‖² (checked by the tests; kept for diagnostics).
    #[allow(dead_code)]
    pub residual_sq: f64,
}

/// R factor of [A | b] for one chunk (at most n+1 rows).
fn chunk_r<L: LinearRows + ?Sized>(sys: &L, rows: Range<usize>) -> DMatrix<f64> {
    let n = sys.n_cols();
    let len = rows.len();
    let mut a = vec![0.0; len * n];
    let mut b = vec![0.0; len];
    sys.fill(rows, &mut a, &mut b);
    a.extend_from_slice(&b);
    let m = DMatrix::from_vec(len, n + 1, a);
    m.qr().r()
}

fn stack_r(top: &DMatrix<f64>, bottom: &DMatrix<f64>) -> DMatrix<f64> {
    let cols = top.ncols();
    let mut m = DMatrix::zeros(top.nrows() + bottom.nrows(), cols);
    m.rows_mut(0, top.nrows()).copy_from(top);
    m.rows_mut(top.nrows(), bottom.nrows()).copy_from(bottom);
    m.qr().r()
}

/// Solves min ‖A x − b‖₂ by TSQR; `what` names the system in errors.
pub(crate) fn solve_lstsq<L: LinearRows + ?Sized>(sys: &L, what: &str) -> Result<LstsqSolution> {
    let m = sys.n_rows();
    let n = sys.n_cols();
    if m < n {
        return Err(FitError::TooFewPoints {
            form: what.to_string(),
            coefficients: n,
            points: m,
        });
    }
    let n_chunks = m.div_ceil(CHUNK_ROWS);
    let mut level: Vec<DMatrix<f64>> = (0..n_chunks)
        .into_par_iter()
        .map(|c| chunk_r(sys, c * CHUNK_ROWS..((c + 1) * CHUNK_ROWS).min(m)))
        .collect();
    // fixed binary-tree reduction: pairs (0,1), (2,3), … level by level
    while level.len() > 1 {
        level = level
            .par_chunks(2)
            .map(|p| {
                if p.len() == 2 {
                    stack_r(&p[0], &p[1])
                } else {
                    p[0].clone()
                }
            })
            .collect();
    }
    let r = level.pop().expect("at least one chunk since m ≥ n ≥ 1");
    // r is (min(m, n+1)) × (n+1): [R11 z; 0 ρ]
    let rr = r.nrows().min(n);
    let r11 = r.view((0, 0), (rr, n)).into_owned();
    let z = r.view((0, n), (rr, 1)).into_owned();
    let residual_sq = if r.nrows() > n {
        r[(n, n)] * r[(n, n)]
    } else {
        0.0
    };

    // column equilibration: the condition number should not depend on the units of a column
    let col_norms: Vec<f64> = (0..n).map(|j| r11.column(j).norm()).collect();
    if let Some(j) = col_norms.iter().position(|&c| !(c > 0.0) || !c.is_finite()) {
        return Err(FitError::Singular {
            what: format!(
                "{what} (column {j} of the design matrix is {})",
                if col_norms[j] == 0.0 {
                    "zero"
                } else {
                    "not finite"
                }
            ),
            condition: f64::INFINITY,
        });
    }
    let mut scaled = r11.clone();
    for j in 0..n {
        scaled.column_mut(j).scale_mut(1.0 / col_norms[j]);
    }
    let svd = scaled.svd(true, true);
    let sv = &svd.singular_values;
    let (smax, smin) = sv
        .iter()
        .fold((0.0f64, f64::INFINITY), |(a, b), &s| (a.max(s), b.min(s)));
    let condition = if rr < n { f64::INFINITY } else { smax / smin };
    if !(condition <= MAX_CONDITION) {
        return Err(FitError::Singular {
            what: what.to_string(),
            condition,
        });
    }
    let (u, vt) = (
        svd.u.as_ref().expect("computed"),
        svd.v_t.as_ref().expect("computed"),
    );
    let uz = u.tr_mul(&z);
    let mut y = DVector::zeros(n);
    for i in 0..n {
        y[i] = uz[i] / sv[i];
    }
    let xs = vt.tr_mul(&y);
    let x: Vec<f64> = (0..n).map(|j| xs[j] / col_norms[j]).collect();
    Ok(LstsqSolution {
        x,
        condition,
        residual_sq,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Dense {
        a: Vec<Vec<f64>>,
        b: Vec<f64>,
    }
    impl LinearRows for Dense {
        fn n_rows(&self) -> usize {
            self.b.len()
        }
        fn n_cols(&self) -> usize {
            self.a[0].len()
        }
        fn fill(&self, rows: Range<usize>, a: &mut [f64], b: &mut [f64]) {
            let len = rows.len();
            for (i, r) in rows.enumerate() {
                for j in 0..self.n_cols() {
                    a[j * len + i] = self.a[r][j];
                }
                b[i] = self.b[r];
            }
        }
    }

    #[test]
    fn exact_line_through_many_chunks() {
        // y = 3 − 2x on 10 000 points: spans several chunks and tree levels
        let m = 10_000;
        let xs: Vec<f64> = (0..m).map(|i| i as f64 / m as f64).collect();
        let sys = Dense {
            a: xs.iter().map(|&x| vec![1.0, x]).collect(),
            b: xs.iter().map(|&x| 3.0 - 2.0 * x).collect(),
        };
        let s = solve_lstsq(&sys, "line").unwrap();
        assert!(
            (s.x[0] - 3.0).abs() < 1e-13 && (s.x[1] + 2.0).abs() < 1e-13,
            "{:?}",
            s.x
        );
        assert!(s.residual_sq < 1e-20);
    }

    #[test]
    fn residual_matches_known_least_squares() {
        // fit a constant to 0, 1, 2, 3: x = 1.5, residual 1.25+0.25+0.25+1.25 = 5
        let sys = Dense {
            a: vec![vec![1.0]; 4],
            b: vec![0.0, 1.0, 2.0, 3.0],
        };
        let s = solve_lstsq(&sys, "const").unwrap();
        assert!((s.x[0] - 1.5).abs() < 1e-15);
        assert!((s.residual_sq - 5.0).abs() < 1e-13);
    }

    #[test]
    fn singular_is_refused() {
        let sys = Dense {
            a: (0..10).map(|i| vec![i as f64, 2.0 * i as f64]).collect(),
            b: vec![1.0; 10],
        };
        let e = solve_lstsq(&sys, "dup").unwrap_err();
        assert!(matches!(e, FitError::Singular { .. }), "{e}");
        assert!(e.to_string().contains("lower the degree"));
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let m = 20_000;
        let sys = Dense {
            a: (0..m)
                .map(|i| {
                    let x = (i as f64 * 0.37).sin();
                    vec![1.0, x, x * x, x * x * x]
                })
                .collect(),
            b: (0..m).map(|i| (i as f64 * 0.11).cos()).collect(),
        };
        let run = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| solve_lstsq(&sys, "t").unwrap().x)
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }
}
