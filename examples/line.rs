use furnace::bsdf::ggx::{Lobes, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::Integrand2D;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (r, mu, beta) = (a[0], a[1], a[2]);
    let f = VndfIntegrand::new(r * r, mu, SmithForm::HeightCorrelated, Lobes::Conductor);
    let mut ob = Vec::new();
    f.outer_breaks(&mut ob);
    println!("outer {ob:?}");
    let mut ib = Vec::new();
    let line = f.line(beta, &mut ib);
    println!("inner {ib:?}");
    let (lo, hi) = (ib[0], *ib.last().unwrap());
    for k in 0..=60 {
        let p = lo + (hi - lo) * (k as f64 / 60.0).powi(3);
        println!("{p:.5} {:.6e}", f.eval(&line, p)[0]);
    }
}
