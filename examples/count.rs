//! Integrand evaluations per cell of the GGX conductor at a few (r, μ): where the quadrature spends its work.
//! `cargo run --release --example count`
use furnace::bsdf::ggx::{Lobes, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Integrand2D, Panel, Rules, CHANNELS};
use std::cell::Cell;
struct C<'a> { f: &'a VndfIntegrand, n: Cell<usize>, lines: Cell<usize> }
impl<'a> Integrand2D for C<'a> {
    type Line = <VndfIntegrand as Integrand2D>::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) { self.f.outer_breaks(o) }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line { self.f.line(u, b) }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] { self.n.set(self.n.get() + 1); self.f.eval(l, v) }
    fn outer_panels(&self, o: &mut Vec<Panel>) { self.f.outer_panels(o) }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line { self.lines.set(self.lines.get() + 1); self.f.line_panels(u, o) }
}
fn main() {
    let rules = Rules::new(12);
    for r in [0.01, 0.05, 0.1, 0.3, 0.6, 1.0] {
        for mu in [0.0, 0.01, 0.1, 0.5, 1.0] {
            let alpha = r * r;
            let f = VndfIntegrand::new(alpha, mu, SmithForm::HeightCorrelated, Lobes::Conductor);
            let c = C { f: &f, n: Cell::new(0), lines: Cell::new(0) };
            let mut op = Vec::new();
            f.outer_panels(&mut op);
            let v = integrate_2d(&c, &rules);
            print!("r={r:<5} mu={mu:<5} E={:.6} outer={} lines={} evals={}  ", v[0], op.len(), c.lines.get(), c.n.get());
            let mut ip = Vec::new(); f.line_panels(0.7, &mut ip);
            println!("inner@0.7={}", ip.len());
        }
    }
}
