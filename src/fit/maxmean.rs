//! The best linear fit in the mixed norm max_i |ρ_i| + λ·mean_i |ρ_i|, ρ = A c − b, as a linear
//! program solved exactly by a primal–dual interior-point method (Mehrotra 1992, "On the
//! implementation of a primal-dual interior point method", predictor–corrector).
//!
//! λ → 0 is the Chebyshev (minimax) fit, λ → ∞ the least-absolute-deviations fit; in between the
//! solutions trace the (max, MAE) Pareto front of the linear model exactly, which is what a
//! sweep's selection asks for (the lowest max error among fits of small mean error). Lawson's
//! reweighting and the L_p homotopy approach that front heuristically; this solves for a point
//! of it.
//!
//! The primal, with t ≥ |ρ_i| and s_i ≥ |ρ_i|,
//!
//!   min t + λ Σ v_i s_i,  v_i = 1/N,
//!
//! has N + n + 1 variables and 4N constraints, and every constraint row holds all n coefficients.
//! Its dual (Rice 1964, "The approximation of functions", §5: the linear-programming form of
//! Chebyshev approximation) has only n + 1 equality rows:
//!
//!   max Σ_i (α_i + β_i) b_i   s.t.  Σ_i (α_i + β_i) a_i = 0,  Σ_i |α_i| ≤ 1,  |β_i| ≤ λ v_i,
//!
//! written here with α = p − q (p, q ≥ 0, Σ (p + q) = 1) and β = z − λ v (0 ≤ z ≤ 2λ v). The
//! normal equations of the interior-point method are then (n + 1) × (n + 1), formed in O(N n²)
//! per iteration, and the fit's coefficients are the dual multipliers of the n rows: c = −y.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::error::{FitError, Result};

/// Interior-point iterations at most (a solve of this size converges in 20–60).
const MAX_ITERATIONS: usize = 150;
/// Fraction of the step to the boundary of the positive orthant.
const STEP_TO_BOUNDARY: f64 = 0.995;
/// Relative duality gap and residuals at which the solve stops.
const TOLERANCE: f64 = 1e-10;
/// Rows per block of the normal matrix's parallel sum.
const BLOCK: usize = 4096;

/// The solution of [`max_mean_fit`].
#[derive(Clone, Debug)]
pub(crate) struct MaxMeanFit {
    /// The coefficients c.
    pub c: Vec<f64>,
}

/// Minimises max_i |a_i·c − b_i| + λ·mean_i |a_i·c − b_i| over c. `a` holds the N rows of A
/// (n = `a.len() / b.len()` numbers each, row-major). Deterministic: the same inputs give the
/// same bits.
pub(crate) fn max_mean_fit(a: &[f64], b: &[f64], lambda: f64) -> Result<MaxMeanFit> {
    let nrows = b.len();
    if nrows == 0 || a.is_empty() || !a.len().is_multiple_of(nrows) {
        return Err(FitError::InvalidSetting {
            name: "max_mean_fit",
            value: format!("{} matrix entries for {} rows", a.len(), nrows),
            expected: "a non-empty matrix with one row per value",
        });
    }
    if !(lambda.is_finite() && lambda >= 0.0) {
        return Err(FitError::InvalidSetting {
            name: "max_mean_lambda",
            value: lambda.to_string(),
            expected: "λ of the max + λ·mean objective must be a finite number ≥ 0",
        });
    }
    let n = a.len() / nrows;
    let m = n + 1;
    let big_n = nrows;
    let v = 1.0 / big_n as f64;
    let row = |i: usize| &a[i * n..(i + 1) * n];
    // variables: p (N), q (N), z (N, with upper bound u = 2λv)
    let u = 2.0 * lambda * v;
    let bounded = u > 0.0;
    // right-hand side: [λ v Σ a_i; 1]
    let mut rhs = vec![0.0; m];
    for i in 0..big_n {
        for (r, x) in rhs.iter_mut().zip(row(i)) {
            *r += lambda * v * x;
        }
    }
    rhs[n] = 1.0;
    // cost: p: −b, q: +b, z: −b (z absent when λ = 0)
    let scale_b = b.iter().fold(0.0f64, |s, x| s.max(x.abs())).max(1e-300);
    // starting point (infeasible start)
    let mut xp = vec![0.5 / big_n as f64; big_n];
    let mut xq = xp.clone();
    let mut xz = vec![if bounded { 0.5 * u } else { 0.0 }; big_n];
    let mut su = xz.clone();
    let mut y = vec![0.0; m];
    let dual0 = scale_b.max(1.0);
    let mut zp = vec![dual0; big_n];
    let mut zq = zp.clone();
    let mut zz = vec![if bounded { dual0 } else { 0.0 }; big_n];
    let mut wz = zz.clone();
    let ncomp = if bounded { 4 * big_n } else { 2 * big_n } as f64;

    // A x: top Σ (p − q + z) a_i, bottom Σ (p + q)
    let a_times = |xp: &[f64], xq: &[f64], xz: &[f64]| -> Vec<f64> {
        let mut out = vec![0.0; m];
        for i in 0..big_n {
            let g = xp[i] - xq[i] + xz[i];
            for (o, x) in out.iter_mut().zip(row(i)) {
                *o += g * x;
            }
            out[n] += xp[i] + xq[i];
        }
        out
    };
    // (A^T y) per column: p: a·y + y0, q: −a·y + y0, z: a·y
    let at_times = |y: &[f64]| -> Vec<f64> {
        (0..big_n)
            .map(|i| row(i).iter().zip(y).map(|(x, y)| x * y).sum())
            .collect()
    };

    for it in 1..=MAX_ITERATIONS {
        let ax = a_times(&xp, &xq, &xz);
        let rb: Vec<f64> = rhs.iter().zip(&ax).map(|(r, x)| r - x).collect();
        let aty = at_times(&y);
        let y0 = y[n];
        // rc = c − A^T y − zd + wd
        let rcp: Vec<f64> = (0..big_n).map(|i| -b[i] - (aty[i] + y0) - zp[i]).collect();
        let rcq: Vec<f64> = (0..big_n).map(|i| b[i] - (-aty[i] + y0) - zq[i]).collect();
        let rcz: Vec<f64> = if bounded {
            (0..big_n).map(|i| -b[i] - aty[i] - zz[i] + wz[i]).collect()
        } else {
            vec![0.0; big_n]
        };
        let ru: Vec<f64> = if bounded {
            (0..big_n).map(|i| u - xz[i] - su[i]).collect()
        } else {
            vec![0.0; big_n]
        };
        let mut comp = 0.0;
        for i in 0..big_n {
            comp += xp[i] * zp[i] + xq[i] * zq[i];
            if bounded {
                comp += xz[i] * zz[i] + su[i] * wz[i];
            }
        }
        let mu = comp / ncomp;
        // objectives: primal c·x, dual b·y − u Σ w
        let pobj: f64 = (0..big_n)
            .map(|i| -b[i] * xp[i] + b[i] * xq[i] - if bounded { b[i] * xz[i] } else { 0.0 })
            .sum();
        let dobj: f64 = rhs.iter().zip(&y).map(|(r, y)| r * y).sum::<f64>()
            - if bounded {
                u * wz.iter().sum::<f64>()
            } else {
                0.0
            };
        let norm = |v: &[f64]| v.iter().fold(0.0f64, |s, x| s.max(x.abs()));
        let primal_res = norm(&rb).max(norm(&ru));
        let dual_res = norm(&rcp).max(norm(&rcq)).max(norm(&rcz));
        if (pobj - dobj).abs() <= TOLERANCE * (1.0 + pobj.abs())
            && primal_res <= TOLERANCE * (1.0 + norm(&rhs))
            && dual_res <= TOLERANCE * (1.0 + scale_b)
        {
            break;
        }
        // Θ per column
        let tp: Vec<f64> = (0..big_n).map(|i| xp[i] / zp[i]).collect();
        let tq: Vec<f64> = (0..big_n).map(|i| xq[i] / zq[i]).collect();
        let tz: Vec<f64> = if bounded {
            (0..big_n)
                .map(|i| 1.0 / (zz[i] / xz[i] + wz[i] / su[i]))
                .collect()
        } else {
            vec![0.0; big_n]
        };
        // normal matrix A Θ A^T
        let mut mat = DMatrix::<f64>::zeros(m, m);
        {
            // Σ_i θ_i a_i a_iᵀ in blocks of rows, summed in block order (the same bits for any
            // number of threads)
            let theta: Vec<f64> = (0..big_n).map(|i| tp[i] + tq[i] + tz[i]).collect();
            let blocks: Vec<DMatrix<f64>> = (0..big_n.div_ceil(BLOCK))
                .into_par_iter()
                .map(|k| {
                    let rows = k * BLOCK..((k + 1) * BLOCK).min(big_n);
                    let mut scaled = DMatrix::<f64>::zeros(rows.len(), n);
                    for (r, i) in rows.enumerate() {
                        let s = theta[i].sqrt();
                        for (j, x) in row(i).iter().enumerate() {
                            scaled[(r, j)] = s * x;
                        }
                    }
                    scaled.transpose() * &scaled
                })
                .collect();
            let mut top = DMatrix::<f64>::zeros(n, n);
            for b in &blocks {
                top += b;
            }
            mat.view_mut((0, 0), (n, n)).copy_from(&top);
            let mut corner = 0.0;
            for i in 0..big_n {
                let g = tp[i] - tq[i];
                for (j, x) in row(i).iter().enumerate() {
                    mat[(j, n)] += g * x;
                }
                corner += tp[i] + tq[i];
            }
            for j in 0..n {
                mat[(n, j)] = mat[(j, n)];
            }
            mat[(n, n)] = corner;
        }
        let trace = (0..m).map(|j| mat[(j, j)]).sum::<f64>() / m as f64;
        let mut chol = None;
        let mut delta = 1e-14 * trace.max(1e-300);
        for _ in 0..12 {
            let mut reg = mat.clone();
            for j in 0..m {
                reg[(j, j)] += delta;
            }
            if let Some(c) = reg.cholesky() {
                chol = Some(c);
                break;
            }
            delta *= 100.0;
        }
        let Some(chol) = chol else {
            return Err(FitError::InvalidSetting {
                name: "max_mean_fit",
                value: format!("iteration {it}"),
                expected: "a matrix of full column rank (the normal equations are singular)",
            });
        };
        // one Newton solve for given complementarity targets
        let solve = |rxp: &[f64], rxq: &[f64], rxz: &[f64], rsw: &[f64]| {
            // ρ = rc − r_xz/x + (r_sw − w ru)/s
            let rhop: Vec<f64> = (0..big_n).map(|i| rcp[i] - rxp[i] / xp[i]).collect();
            let rhoq: Vec<f64> = (0..big_n).map(|i| rcq[i] - rxq[i] / xq[i]).collect();
            let rhoz: Vec<f64> = if bounded {
                (0..big_n)
                    .map(|i| rcz[i] - rxz[i] / xz[i] + (rsw[i] - wz[i] * ru[i]) / su[i])
                    .collect()
            } else {
                vec![0.0; big_n]
            };
            // rb + A Θ ρ
            let mut r = DVector::from_vec(rb.clone());
            for i in 0..big_n {
                let g = tp[i] * rhop[i] - tq[i] * rhoq[i] + tz[i] * rhoz[i];
                for (j, x) in row(i).iter().enumerate() {
                    r[j] += g * x;
                }
                r[n] += tp[i] * rhop[i] + tq[i] * rhoq[i];
            }
            let dy = chol.solve(&r);
            let dy: Vec<f64> = dy.iter().copied().collect();
            let atdy = at_times(&dy);
            let dxp: Vec<f64> = (0..big_n)
                .map(|i| tp[i] * (atdy[i] + dy[n] - rhop[i]))
                .collect();
            let dxq: Vec<f64> = (0..big_n)
                .map(|i| tq[i] * (-atdy[i] + dy[n] - rhoq[i]))
                .collect();
            let dxz: Vec<f64> = if bounded {
                (0..big_n).map(|i| tz[i] * (atdy[i] - rhoz[i])).collect()
            } else {
                vec![0.0; big_n]
            };
            let dzp: Vec<f64> = (0..big_n)
                .map(|i| (rxp[i] - zp[i] * dxp[i]) / xp[i])
                .collect();
            let dzq: Vec<f64> = (0..big_n)
                .map(|i| (rxq[i] - zq[i] * dxq[i]) / xq[i])
                .collect();
            let (dzz, dsu, dwz): (Vec<f64>, Vec<f64>, Vec<f64>) = if bounded {
                let dzz = (0..big_n)
                    .map(|i| (rxz[i] - zz[i] * dxz[i]) / xz[i])
                    .collect();
                let dsu: Vec<f64> = (0..big_n).map(|i| ru[i] - dxz[i]).collect();
                let dwz = (0..big_n)
                    .map(|i| (rsw[i] - wz[i] * dsu[i]) / su[i])
                    .collect();
                (dzz, dsu, dwz)
            } else {
                (vec![0.0; big_n], vec![0.0; big_n], vec![0.0; big_n])
            };
            Step {
                dy,
                dxp,
                dxq,
                dxz,
                dsu,
                dzp,
                dzq,
                dzz,
                dwz,
            }
        };
        let bound_step = |x: &[f64], dx: &[f64], alpha: f64| {
            x.iter()
                .zip(dx)
                .fold(alpha, |a, (x, d)| if *d < 0.0 { a.min(-x / d) } else { a })
        };
        let steps = |s: &Step| {
            let mut ap = bound_step(&xp, &s.dxp, 1.0);
            ap = bound_step(&xq, &s.dxq, ap);
            let mut ad = bound_step(&zp, &s.dzp, 1.0);
            ad = bound_step(&zq, &s.dzq, ad);
            if bounded {
                ap = bound_step(&xz, &s.dxz, ap);
                ap = bound_step(&su, &s.dsu, ap);
                ad = bound_step(&zz, &s.dzz, ad);
                ad = bound_step(&wz, &s.dwz, ad);
            }
            (ap, ad)
        };
        // predictor
        let neg =
            |x: &[f64], z: &[f64]| -> Vec<f64> { x.iter().zip(z).map(|(x, z)| -x * z).collect() };
        let aff = solve(
            &neg(&xp, &zp),
            &neg(&xq, &zq),
            &neg(&xz, &zz),
            &neg(&su, &wz),
        );
        let (ap, ad) = steps(&aff);
        let mut comp_aff = 0.0;
        for i in 0..big_n {
            comp_aff += (xp[i] + ap * aff.dxp[i]) * (zp[i] + ad * aff.dzp[i])
                + (xq[i] + ap * aff.dxq[i]) * (zq[i] + ad * aff.dzq[i]);
            if bounded {
                comp_aff += (xz[i] + ap * aff.dxz[i]) * (zz[i] + ad * aff.dzz[i])
                    + (su[i] + ap * aff.dsu[i]) * (wz[i] + ad * aff.dwz[i]);
            }
        }
        let sigma = (comp_aff / ncomp / mu).powi(3).clamp(0.0, 1.0);
        let target = sigma * mu;
        let corr = |x: &[f64], z: &[f64], dx: &[f64], dz: &[f64]| -> Vec<f64> {
            (0..big_n)
                .map(|i| target - x[i] * z[i] - dx[i] * dz[i])
                .collect()
        };
        let step = solve(
            &corr(&xp, &zp, &aff.dxp, &aff.dzp),
            &corr(&xq, &zq, &aff.dxq, &aff.dzq),
            &if bounded {
                corr(&xz, &zz, &aff.dxz, &aff.dzz)
            } else {
                vec![0.0; big_n]
            },
            &if bounded {
                corr(&su, &wz, &aff.dsu, &aff.dwz)
            } else {
                vec![0.0; big_n]
            },
        );
        let (ap, ad) = steps(&step);
        let (ap, ad) = (
            (STEP_TO_BOUNDARY * ap).min(1.0),
            (STEP_TO_BOUNDARY * ad).min(1.0),
        );
        let upd = |x: &mut [f64], dx: &[f64], a: f64| {
            for (x, d) in x.iter_mut().zip(dx) {
                *x += a * d;
            }
        };
        upd(&mut xp, &step.dxp, ap);
        upd(&mut xq, &step.dxq, ap);
        upd(&mut y, &step.dy, ad);
        upd(&mut zp, &step.dzp, ad);
        upd(&mut zq, &step.dzq, ad);
        if bounded {
            upd(&mut xz, &step.dxz, ap);
            upd(&mut su, &step.dsu, ap);
            upd(&mut zz, &step.dzz, ad);
            upd(&mut wz, &step.dwz, ad);
        }
    }
    let c: Vec<f64> = y[..n].iter().map(|y| -y).collect();
    if c.iter().any(|c| !c.is_finite()) {
        return Err(FitError::InvalidSetting {
            name: "max_mean_fit",
            value: "a non-finite solution".into(),
            expected: "finite matrix entries and values",
        });
    }
    Ok(MaxMeanFit { c })
}

/// A Newton direction of the interior-point method.
struct Step {
    dy: Vec<f64>,
    dxp: Vec<f64>,
    dxq: Vec<f64>,
    dxz: Vec<f64>,
    dsu: Vec<f64>,
    dzp: Vec<f64>,
    dzq: Vec<f64>,
    dzz: Vec<f64>,
    dwz: Vec<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (max, mean) of |A c − b|.
    fn errors(a: &[f64], b: &[f64], c: &[f64]) -> (f64, f64) {
        let n = c.len();
        let e: Vec<f64> = b
            .iter()
            .enumerate()
            .map(|(i, b)| {
                (a[i * n..(i + 1) * n]
                    .iter()
                    .zip(c)
                    .map(|(a, c)| a * c)
                    .sum::<f64>()
                    - b)
                    .abs()
            })
            .collect();
        (
            e.iter().fold(0.0f64, |m, x| m.max(*x)),
            e.iter().sum::<f64>() / e.len() as f64,
        )
    }

    /// The line a + b x at `xs` (rows [1, x]).
    fn line_rows(xs: &[f64]) -> Vec<f64> {
        xs.iter().flat_map(|&x| [1.0, x]).collect()
    }

    #[test]
    fn small_lambda_is_the_chebyshev_line_of_a_parabola() {
        // the best line to x² on [0, 1] in max norm: x − 1/8 (equioscillation at 0, ½, 1)
        let xs: Vec<f64> = (0..=200).map(|i| i as f64 / 200.0).collect();
        let b: Vec<f64> = xs.iter().map(|x| x * x).collect();
        let rows = line_rows(&xs);
        let f = max_mean_fit(&rows, &b, 1e-6).unwrap();
        assert!(
            (f.c[0] + 0.125).abs() < 1e-6 && (f.c[1] - 1.0).abs() < 1e-6,
            "{f:?}"
        );
        assert!((errors(&rows, &b, &f.c).0 - 0.125).abs() < 1e-6, "{f:?}");
        // λ = 0 exactly (no bounded part) gives the same line
        let g = max_mean_fit(&rows, &b, 0.0).unwrap();
        assert!((errors(&rows, &b, &g.c).0 - 0.125).abs() < 1e-8, "{g:?}");
    }

    #[test]
    fn large_lambda_is_the_least_absolute_deviations_fit() {
        // a constant fitted to values: the L1 fit is their median, the L∞ fit the midrange
        let b = [0.0, 1.0, 2.0, 3.0, 10.0];
        let ones = [1.0; 5];
        let l1 = max_mean_fit(&ones, &b, 1e4).unwrap();
        assert!((l1.c[0] - 2.0).abs() < 1e-6, "{l1:?}");
        let linf = max_mean_fit(&ones, &b, 0.0).unwrap();
        assert!((linf.c[0] - 5.0).abs() < 1e-6, "{linf:?}");
        // in between: the objective max + λ·mean at the solution is no larger than at
        // nearby constants (a convex function of one variable, so that is optimality)
        let lam = 2.0;
        let mid = max_mean_fit(&ones, &b, lam).unwrap();
        let obj = |c: f64| {
            let e: Vec<f64> = b.iter().map(|x| (c - x).abs()).collect();
            e.iter().fold(0.0f64, |m, x| m.max(*x)) + lam * e.iter().sum::<f64>() / 5.0
        };
        let at = obj(mid.c[0]);
        for d in [-0.1, -0.01, -1e-4, 1e-4, 0.01, 0.1] {
            assert!(
                at <= obj(mid.c[0] + d) + 1e-9,
                "{d}: {at} vs {}",
                obj(mid.c[0] + d)
            );
        }
    }

    #[test]
    fn the_front_trades_max_for_mean_and_is_deterministic() {
        // a cubic with an outlier-like spike fitted by a quadratic
        let xs: Vec<f64> = (0..=300).map(|i| i as f64 / 300.0).collect();
        let b: Vec<f64> = xs
            .iter()
            .map(|x| x * x * x + 0.3 * (-(x - 0.8) * (x - 0.8) / 1e-3).exp())
            .collect();
        let rows: Vec<f64> = xs.iter().flat_map(|&x| [1.0, x, x * x]).collect();
        let fits: Vec<MaxMeanFit> = [0.0, 0.5, 4.0, 64.0]
            .iter()
            .map(|&l| max_mean_fit(&rows, &b, l).unwrap())
            .collect();
        let front: Vec<(f64, f64)> = fits.iter().map(|f| errors(&rows, &b, &f.c)).collect();
        for w in front.windows(2) {
            assert!(w[1].0 >= w[0].0 - 1e-9, "{front:?}");
            assert!(w[1].1 <= w[0].1 + 1e-9, "{front:?}");
        }
        assert!(
            front[3].1 < 0.9 * front[0].1 && front[3].0 > 1.1 * front[0].0,
            "{front:?}"
        );
        let again = max_mean_fit(&rows, &b, 4.0).unwrap();
        assert_eq!(again.c, fits[2].c);
    }

    #[test]
    fn bad_input_is_refused() {
        assert!(max_mean_fit(&[], &[], 1.0).is_err());
        assert!(max_mean_fit(&[1.0, 2.0, 3.0], &[1.0, 2.0], 1.0).is_err());
        let e = max_mean_fit(&[1.0], &[1.0], f64::NAN)
            .unwrap_err()
            .to_string();
        assert!(e.contains("λ"), "{e}");
    }
}
