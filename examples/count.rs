//! Integrand evaluations per conductor cell at a few (r, μ), for the estimate's two orders (9 and
//! 12): the slope-space integrand the conductor uses (`bsdf::slope`) against the visible-normal
//! one it used before (`bsdf::ggx`). `cargo run --release --example count`
use furnace::bsdf::ggx::{Lobes, VndfIntegrand};
use furnace::bsdf::slope::SlopeIntegrand;
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Integrand2D, Panel, Rules, CHANNELS};
use std::cell::Cell;

/// Counts evaluations and lines of `f` (through `eval`, so every node is counted once).
struct Count<'a, I: Integrand2D> {
    f: &'a I,
    n: Cell<usize>,
    lines: Cell<usize>,
}

impl<'a, I: Integrand2D> Integrand2D for Count<'a, I> {
    type Line = I::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) {
        self.f.outer_breaks(o)
    }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line {
        self.f.line(u, b)
    }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] {
        self.n.set(self.n.get() + 1);
        self.f.eval(l, v)
    }
    fn outer_panels(&self, o: &mut Vec<Panel>) {
        self.f.outer_panels(o)
    }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line {
        self.lines.set(self.lines.get() + 1);
        self.f.line_panels(u, o)
    }
    fn lean_outer(&self) -> bool {
        self.f.lean_outer()
    }
    fn panels_all_active(&self) -> bool {
        self.f.panels_all_active()
    }
}

fn count<I: Integrand2D>(f: &I) -> (f64, usize, usize) {
    let c = Count { f, n: Cell::new(0), lines: Cell::new(0) };
    let e = integrate_2d(&c, &Rules::new(12))[0];
    integrate_2d(&c, &Rules::new(9));
    (e, c.lines.get(), c.n.get())
}

fn main() {
    println!("{:>5} {:>5} | {:>9} {:>6} {:>6} | {:>9} {:>6} {:>6}", "r", "mu", "E vndf", "lines", "evals", "E slope", "lines", "evals");
    for r in [0.01, 0.05, 0.1, 0.3, 0.6, 1.0] {
        for mu in [0.0, 0.01, 0.1, 0.5, 1.0] {
            let alpha = r * r;
            let (ev, lv, nv) = count(&VndfIntegrand::new(alpha, mu, SmithForm::HeightCorrelated, Lobes::Conductor));
            let (es, ls, ns) = count(&SlopeIntegrand::conductor(alpha, mu, SmithForm::HeightCorrelated));
            println!("{r:>5} {mu:>5} | {ev:>9.6} {lv:>6} {nv:>6} | {es:>9.6} {ls:>6} {ns:>6}");
        }
    }
}
