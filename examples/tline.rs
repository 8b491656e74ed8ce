use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::Integrand2D;
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (eta, r, mu, beta) = (a[0], a[1], a[2], a[3]);
    let f = VndfIntegrand::part(r * r, mu, SmithForm::HeightCorrelated, Lobes::Dielectric { eta }, Part::TransmissionOnly);
    let mut ip = Vec::new();
    let line = f.line_panels(beta, &mut ip);
    let (lo, hi) = (ip[0].a, ip.last().unwrap().b);
    for k in 0..=50 { let p = lo + (hi - lo) * (k as f64 / 50.0).powi(4); println!("{p:.4} {:.6e}", f.eval(&line, p)[1]); }
}
