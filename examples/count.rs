use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Integrand2D, Panel, Rules, CHANNELS};
use std::cell::Cell;
struct C<'a> { f: &'a VndfIntegrand, evals: Cell<usize>, lines: Cell<usize>, panels: Cell<usize> }
impl<'a> Integrand2D for C<'a> {
    type Line = <VndfIntegrand as Integrand2D>::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) { self.f.outer_breaks(o) }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line { self.f.line(u, b) }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] { self.evals.set(self.evals.get() + 1); self.f.eval(l, v) }
    fn outer_panels(&self, o: &mut Vec<Panel>) { self.f.outer_panels(o); println!("outer panels {}", o.len()); }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line { self.lines.set(self.lines.get() + 1); let l = self.f.line_panels(u, o); self.panels.set(self.panels.get() + o.len()); l }
}
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let f = VndfIntegrand::part(a[0] * a[0], a[1], SmithForm::HeightCorrelated, match std::env::var("ETA") { Ok(e) => Lobes::Dielectric { eta: e.parse().unwrap() }, Err(_) => Lobes::Conductor }, match std::env::var("PART").as_deref() { Ok("T") => Part::TransmissionOnly, Ok("R") => Part::ReflectionOnly, _ => Part::Both });
    let c = C { f: &f, evals: Cell::new(0), lines: Cell::new(0), panels: Cell::new(0) };
    let v = integrate_2d(&c, &Rules::new(16));
    println!("E {:.12} evals {} lines {} inner panels/line {:.2}", v[0], c.evals.get(), c.lines.get(), c.panels.get() as f64 / c.lines.get() as f64);
}
