//! Integrand evaluations per conductor cell at a few (r, μ), for the estimate's two orders (9 and
//! 12): the slope-space integrand the conductor uses (`bsdf::slope`) against the visible-normal
//! one of the other GGX models (`bsdf::vndf`). `cargo run --release --example count`
use furnace::bsdf::microfacet::Lobes;
use furnace::bsdf::slope::SlopeIntegrand;
use furnace::bsdf::vndf::VndfIntegrand;
use furnace::math::SmithForm;
use furnace::quadrature::{integrate_2d, Integrand2D, Rules};

#[path = "common/counted.rs"]
mod counted;
use counted::Counted;

fn count<I: Integrand2D>(f: &I) -> (f64, usize, usize) {
    let c = Counted::new(f, None);
    let e = integrate_2d(&c, &Rules::new(12))[0];
    integrate_2d(&c, &Rules::new(9));
    (e, c.lines.get(), c.evals.get())
}

fn main() {
    println!(
        "{:>5} {:>5} | {:>9} {:>6} {:>6} | {:>9} {:>6} {:>6}",
        "r", "mu", "E vndf", "lines", "evals", "E slope", "lines", "evals"
    );
    for r in [0.01, 0.05, 0.1, 0.3, 0.6, 1.0] {
        for mu in [0.0, 0.01, 0.1, 0.5, 1.0] {
            let alpha = r * r;
            let (ev, lv, nv) = count(&VndfIntegrand::new(
                alpha,
                mu,
                SmithForm::HeightCorrelated,
                Lobes::Conductor,
            ));
            let (es, ls, ns) = count(&SlopeIntegrand::conductor(
                alpha,
                mu,
                SmithForm::HeightCorrelated,
            ));
            println!("{r:>5} {mu:>5} | {ev:>9.6} {lv:>6} {nv:>6} | {es:>9.6} {ls:>6} {ns:>6}");
        }
    }
}
