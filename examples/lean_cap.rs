//! The leaving dielectric's critical-angle cap ([`SlopeDielectric::deficit`]) with its outer
//! variable ψ at the full order (what it uses) against `lean_order`: first the error of each
//! variable's rule alone at order 9 (the other at 40) over 5 IORs × 16 × 17 cells of (F0, r, μ),
//! then, on a 5 × 23 × 24 grid, the cells whose estimate |Q(12) − Q(9)| misses 1e-7 (refined
//! ×1.25 until it meets it) and the worst error after that against order 36.
//! `cargo run --release --example lean_cap`
use furnace::bsdf::slope_dielectric::SlopeDielectric;
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, next_order, Integrand2D, Panel, Rules, CHANNELS};

/// The cap with the full (false) or lean (true) outer rule.
struct Outer<'a>(&'a SlopeDielectric, bool);

impl Integrand2D for Outer<'_> {
    type Line = <SlopeDielectric as Integrand2D>::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) {
        self.0.outer_breaks(o)
    }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line {
        self.0.line(u, b)
    }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] {
        self.0.eval(l, v)
    }
    fn outer_panels(&self, o: &mut Vec<Panel>) {
        self.0.outer_panels(o)
    }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line {
        self.0.line_panels(u, o)
    }
    fn lean_outer(&self) -> bool {
        self.1
    }
    fn panels_all_active(&self) -> bool {
        self.0.panels_all_active()
    }
    fn accumulate_nodes(&self, l: &Self::Line, vs: &[f64], ws: &[f64], acc: &mut [f64]) {
        self.0.accumulate_nodes(l, vs, ws, acc)
    }
}

fn diff(a: [f64; CHANNELS], b: [f64; CHANNELS]) -> f64 {
    (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
}

fn main() {
    let smith = SmithForm::HeightCorrelated;
    // relative IORs 1/η seen from inside, over the table's F0 range
    let etas: Vec<f64> = [0.0125f64, 0.05, 0.1, 0.18, 0.25]
        .iter()
        .map(|&f0| (1.0 - f0.sqrt()) / (1.0 + f0.sqrt()))
        .collect();
    let (mut outer9, mut inner9) = (0.0f64, 0.0f64);
    for &eta in &etas {
        for i in 1..=16 {
            for j in 0..=16 {
                let (r, mu) = (i as f64 / 16.0, j as f64 / 16.0);
                let f = SlopeDielectric::deficit(r * r, mu, eta, smith);
                let exact = integrate_2d(&f, &Rules::new(40));
                outer9 = outer9.max(diff(integrate_2d(&f, &Rules::with_orders(9, 40)), exact));
                inner9 = inner9.max(diff(integrate_2d(&f, &Rules::with_orders(40, 9)), exact));
            }
        }
    }
    println!("order 9 in one variable, 40 in the other: outer ψ {outer9:.1e}, inner {inner9:.1e}");
    let n = 24;
    for lean in [false, true] {
        let (mut refined, mut worst, mut cells) = (0, 0.0f64, 0);
        for &eta in &etas {
            for i in 1..n {
                for j in 0..n {
                    let (r, mu) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                    let f = SlopeDielectric::deficit(r * r, mu, eta, smith);
                    let c = Outer(&f, lean);
                    let mut value = integrate_2d(&c, &Rules::new(12));
                    let mut estimate = diff(integrate_2d(&c, &Rules::new(9)), value);
                    let mut order = 12;
                    if estimate > 1e-7 {
                        refined += 1;
                    }
                    while estimate > 1e-7 && order < 96 {
                        order = next_order(order);
                        let next = integrate_2d(&c, &Rules::new(order));
                        estimate = diff(next, value);
                        value = next;
                    }
                    worst = worst.max(diff(value, integrate_2d(&f, &Rules::new(36))));
                    cells += 1;
                }
            }
        }
        let outer = if lean {
            "lean_order (10/8/13)"
        } else {
            "full (12/9/15)"
        };
        println!("outer {outer:<22} refined {refined:4} of {cells}  worst error {worst:.1e}");
    }
}
