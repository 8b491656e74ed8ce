use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::Integrand2D;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (eta, r, mu, beta, lo, hi) = (a[0], a[1], a[2], a[3], a[4], a[5]);
    let f = VndfIntegrand::part(r * r, mu, SmithForm::HeightCorrelated, Lobes::Dielectric { eta }, Part::ReflectionOnly);
    let mut ip = Vec::new();
    let line = f.line_panels(beta, &mut ip);
    let n = 400;
    let v: Vec<f64> = (0..=n).map(|k| f.eval(&line, lo + (hi - lo) * k as f64 / n as f64)[0]).collect();
    // print second differences to spot kinks
    let mut worst = (0.0, 0.0);
    for k in 1..n { let d2 = (v[k+1] - 2.0*v[k] + v[k-1]).abs(); if d2 > worst.0 { worst = (d2, lo + (hi-lo)*k as f64/n as f64); } }
    println!("max |d2| {:.3e} at {:.5}", worst.0, worst.1);
    for k in (0..=n).step_by(20) { println!("{:.5} {:.8e}", lo + (hi-lo)*k as f64/n as f64, v[k]); }
}
