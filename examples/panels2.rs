use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::{SmithForm, eta_from_f0};
use furnace::quadrature::{Integrand2D, integrate_2d, Rules, Panel, CHANNELS};
struct One<'a> { f: &'a VndfIntegrand, p: Panel }
impl<'a> Integrand2D for One<'a> {
    type Line = <VndfIntegrand as Integrand2D>::Line;
    fn outer_breaks(&self, o: &mut Vec<f64>) { self.f.outer_breaks(o) }
    fn line(&self, u: f64, b: &mut Vec<f64>) -> Self::Line { self.f.line(u, b) }
    fn eval(&self, l: &Self::Line, v: f64) -> [f64; CHANNELS] { self.f.eval(l, v) }
    fn outer_panels(&self, o: &mut Vec<Panel>) { o.push(self.p) }
    fn line_panels(&self, u: f64, o: &mut Vec<Panel>) -> Self::Line { self.f.line_panels(u, o) }
}
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|s| s.parse().unwrap()).collect();
    let (f0, r, mu) = (a[0], a[1], a[2]);
    let eta = 1.0 / eta_from_f0(f0);
    let f = VndfIntegrand::part(r * r, mu, SmithForm::HeightCorrelated, Lobes::Dielectric { eta }, Part::ReflectionOnly);
    let mut op = Vec::new();
    f.outer_panels(&mut op);
    for p in op {
        let g = One { f: &f, p };
        let refv = integrate_2d(&g, &Rules::new(96));
        print!("{:.4}-{:.4}:", p.a, p.b);
        for o in [8, 12, 16, 24, 32] { let v = integrate_2d(&g, &Rules::with_orders(o, 48)); print!(" {o}:{:.1e}", v[0] - refv[0]); }
        println!();
    }
}
