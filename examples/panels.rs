use furnace::bsdf::ggx::{Lobes, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::{Integrand2D, Rules};
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (r, mu, beta) = (a[0], a[1], a[2]);
    let f = VndfIntegrand::new(r * r, mu, if std::env::var("SEP").is_ok() { SmithForm::Separable } else { SmithForm::HeightCorrelated }, match std::env::var("ETA") { Ok(e) => Lobes::Dielectric { eta: e.parse().unwrap() }, Err(_) => Lobes::Conductor });
    let mut op = Vec::new();
    f.outer_panels(&mut op);
    for p in &op { println!("outer {:?}", p); }
    let mut ip = Vec::new();
    let line = f.line_panels(beta, &mut ip);
    for p in &ip {
        let q = |n: usize| -> f64 { let mut s = 0.0; Rules::new(n).inner.for_each_node(p, |x, w| s += w * f.eval(&line, x)[std::env::var("CH").map(|c| c.parse::<usize>().unwrap()).unwrap_or(0)]); s };
        let refv = q(1024);
        let mut s = format!("{:?} {refv:.10e}", p);
        for n in [8, 16, 32, 64] { s += &format!(" {:.1e}", q(n) - refv); }
        println!("{s}");
    }
}
