use furnace::bsdf::ggx::{Lobes, Part, VndfIntegrand};
use furnace::math::SmithForm;
use furnace::quadrature::{Integrand2D, Rules};
fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (r, mu) = (a[0], a[1]);
    let f = VndfIntegrand::part(r * r, mu, if std::env::var("SEP").is_ok() { SmithForm::Separable } else { SmithForm::HeightCorrelated }, match std::env::var("ETA") { Ok(e) => Lobes::Dielectric { eta: e.parse().unwrap() }, Err(_) => Lobes::Conductor }, match std::env::var("PART").as_deref() { Ok("T") => Part::TransmissionOnly, Ok("R") => Part::ReflectionOnly, _ => Part::Both });
    let (r16, r1k) = (Rules::new(16), Rules::new(1024));
    let mut worst = (0.0, 0.0);
    for k in 0..2000 {
        let beta = (k as f64 + 0.5) / 2000.0 * std::f64::consts::FRAC_PI_2;
        let mut ip = Vec::new();
        let line = f.line_panels(beta, &mut ip);
        let q = |r: &Rules| -> f64 { let mut s = 0.0; for p in &ip { r.inner.for_each_node(p, |x, w| s += w * f.eval(&line, x)[std::env::var("CH").map(|c| c.parse::<usize>().unwrap()).unwrap_or(0)]); } s };
        let e = (q(&r16) - q(&r1k)).abs();
        if e > worst.0 { worst = (e, beta); }
    }
    println!("worst inner err {:.2e} at beta {}", worst.0, worst.1);
    let mut ip = Vec::new();
    let _ = f.line_panels(worst.1, &mut ip);
    let line = f.line_panels(worst.1, &mut Vec::new());
    for p in ip {
        let q = |n: usize| -> f64 { let mut s = 0.0; Rules::new(n).inner.for_each_node(&p, |x, w| s += w * f.eval(&line, x)[std::env::var("CH").map(|c| c.parse::<usize>().unwrap()).unwrap_or(0)]); s };
        println!("{p:?} {:.3e} {:.1e} {:.1e}", q(1024), q(16) - q(1024), q(32) - q(1024));
    }
}
#[allow(dead_code)]
fn unused() {}
