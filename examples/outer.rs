use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::{Integrand2D, Rules};
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (r, mu) = (a[0], a[1]);
    let f = VndfIntegrand::part(r * r, mu, if std::env::var("SEP").is_ok() { SmithForm::Separable } else { SmithForm::HeightCorrelated }, match std::env::var("ETA") { Ok(e) => Lobes::Dielectric { eta: e.parse().unwrap() }, Err(_) => Lobes::Conductor }, match std::env::var("PART").as_deref() { Ok("T") => Part::TransmissionOnly, Ok("R") => Part::ReflectionOnly, _ => Part::Both });
    let inner = Rules::new(32);
    let g = |beta: f64| -> f64 { let mut ip = Vec::new(); let line = f.line_panels(beta, &mut ip); let mut s = 0.0; for p in &ip { inner.inner.for_each_node(p, |x, w| s += w * f.eval(&line, x)[std::env::var("CH").map(|c| c.parse::<usize>().unwrap()).unwrap_or(0)]); } s };
    let mut op = Vec::new();
    f.outer_panels(&mut op);
    for p in &op {
        let q = |n: usize| -> f64 { let mut s = 0.0; Rules::new(n).outer.for_each_node(p, |x, w| s += w * g(x)); s };
        let refv = q(400);
        println!("{p:?} {refv:.6e} {:.1e} {:.1e} {:.1e} {:.1e}", q(8) - refv, q(16) - refv, q(32) - refv, q(64) - refv);
    }
    if a.len() > 2 { for k in 0..=40 { let b = op[0].a + (op.last().unwrap().b - op[0].a) * k as f64 / 40.0; println!("{b:.4} {:.6e}", g(b)); } }
}
