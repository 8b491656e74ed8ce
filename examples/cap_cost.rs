//! Where the leaving dielectric's table spends its time: the critical-angle cap
//! ([`SlopeDielectric::deficit`], height-correlated) of every cell of an n³ grid of (F0, r, μ)
//! (F0 ∈ [0.0125, 0.25], r ∈ (0, 1], μ ∈ [0, 1], the table's nodes but r = 0), integrated at both
//! orders of its estimate (12 and 9), its time (mean of three runs), lines and integrand
//! evaluations, grouped by μ − μc in units of α (μc the critical cosine) and by r.
//! `cargo run --release --example cap_cost [n]` (default 32).
use furnace::bsdf::slope_dielectric::SlopeDielectric;
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Rules};
#[path = "common/counted.rs"]
mod counted;
use counted::Counted;
use std::time::Instant;

/// One cell: r, μ − μc in units of α, seconds, lines, evaluations.
struct Cost {
    r: f64,
    from_critical: f64,
    seconds: f64,
    lines: usize,
    evals: usize,
}

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(32);
    let (r12, r9) = (Rules::new(12), Rules::new(9));
    let mut cells = Vec::new();
    for i in 0..n {
        let f0 = 0.0125 + (0.25 - 0.0125) * i as f64 / (n - 1) as f64;
        // leaving the denser medium: relative IOR 1/η, η = (1 + √F0)/(1 − √F0)
        let eta = (1.0 - f0.sqrt()) / (1.0 + f0.sqrt());
        let mu_c = (1.0 - eta * eta).sqrt();
        for j in 1..n {
            let r = j as f64 / (n - 1) as f64;
            let alpha = r * r;
            for k in 0..n {
                let mu = k as f64 / (n - 1) as f64;
                let cap = SlopeDielectric::deficit(alpha, mu, eta, SmithForm::HeightCorrelated);
                let counted = Counted::new(&cap, None);
                integrate_2d(&counted, &r12);
                integrate_2d(&counted, &r9);
                let start = Instant::now();
                for _ in 0..3 {
                    std::hint::black_box(integrate_2d(&cap, &r12));
                    std::hint::black_box(integrate_2d(&cap, &r9));
                }
                cells.push(Cost {
                    r,
                    from_critical: (mu - mu_c) / alpha,
                    seconds: start.elapsed().as_secs_f64() / 3.0,
                    lines: counted.lines.get(),
                    evals: counted.evals.get(),
                });
            }
        }
    }
    let total: f64 = cells.iter().map(|c| c.seconds).sum();
    println!("{} cells, {:.3} s at orders 12 and 9", cells.len(), total);
    let row = |label: &str, keep: &dyn Fn(&Cost) -> bool| {
        let sel: Vec<&Cost> = cells.iter().filter(|c| keep(c)).collect();
        let m = sel.len().max(1) as f64;
        let t: f64 = sel.iter().map(|c| c.seconds).sum();
        println!(
            "{label:>24}: {:6} cells, {:5.1} % of the time, {:6.1} lines and {:6.0} evaluations per cell, {:6.1} µs per cell",
            sel.len(),
            100.0 * t / total,
            sel.iter().map(|c| c.lines).sum::<usize>() as f64 / m,
            sel.iter().map(|c| c.evals).sum::<usize>() as f64 / m,
            1e6 * t / m
        );
    };
    let bands = [
        (f64::NEG_INFINITY, -4.0),
        (-4.0, -1.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (1.0, 4.0),
        (4.0, f64::INFINITY),
    ];
    for (lo, hi) in bands {
        row(&format!("(μ − μc)/α in [{lo}, {hi})"), &|c| {
            c.from_critical >= lo && c.from_critical < hi
        });
    }
    for q in 0..4 {
        let (lo, hi) = (q as f64 / 4.0, (q + 1) as f64 / 4.0);
        row(&format!("r in ({lo}, {hi}]"), &|c| c.r > lo && c.r <= hi);
    }
}
