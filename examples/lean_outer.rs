//! The slope-space conductor with its outer variable ψ at the full order against `lean_order`
//! (what it uses): evaluations per cell, cells whose estimate |Q(12) − Q(9)| misses 1e-7 (refined
//! once, at 15), and the worst error after that against order 30, on a 48² grid of (r, μ); first,
//! the error of each variable's rule alone at order 9 (the other at 40) on a 20² grid.
//! `cargo run --release --example lean_outer`
use furnace::bsdf::slope::SlopeIntegrand;
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Rules};

#[path = "common/counted.rs"]
mod counted;
use counted::Counted;

fn main() {
    let (q9, q12, q15, truth) = (
        Rules::new(9),
        Rules::new(12),
        Rules::new(15),
        Rules::new(30),
    );
    let (mut outer9, mut inner9) = (0.0f64, 0.0f64);
    for i in 1..=20 {
        for j in 0..20 {
            let (r, mu) = (i as f64 / 20.0, j as f64 / 19.0);
            let f = SlopeIntegrand::conductor(r * r, mu, SmithForm::HeightCorrelated);
            let full = Counted::new(&f, Some(false));
            let exact = integrate_2d(&full, &Rules::new(40))[0];
            outer9 = outer9.max((integrate_2d(&full, &Rules::with_orders(9, 40))[0] - exact).abs());
            inner9 = inner9.max((integrate_2d(&full, &Rules::with_orders(40, 9))[0] - exact).abs());
        }
    }
    println!("order 9 in one variable, 40 in the other, worst over 20²: outer ψ {outer9:.1e}, inner {inner9:.1e}");
    let n = 48;
    for lean in [false, true] {
        let (mut evals, mut refined, mut worst, mut cells) = (0usize, 0usize, 0.0f64, 0usize);
        for i in 1..n {
            let r = i as f64 / (n - 1) as f64;
            for j in 0..n {
                let mu = j as f64 / (n - 1) as f64;
                let f = SlopeIntegrand::conductor(r * r, mu, SmithForm::HeightCorrelated);
                let c = Counted::new(&f, Some(lean));
                let (a, b) = (integrate_2d(&c, &q9)[0], integrate_2d(&c, &q12)[0]);
                let mut value = b;
                if (a - b).abs() > 1e-7 {
                    value = integrate_2d(&c, &q15)[0];
                    refined += 1;
                }
                evals += c.evals.get();
                cells += 1;
                worst = worst.max((value - integrate_2d(&f, &truth)[0]).abs());
            }
        }
        let outer = if lean {
            "lean_order (10/8/13)"
        } else {
            "full (12/9/15)"
        };
        println!(
            "outer {outer:<22} evaluations/cell {:6.0}  refined {refined:4} of {cells}  worst error {worst:.1e}",
            evals as f64 / cells as f64
        );
    }
}
