use furnace::bsdf::{find, ModelOptions};
use furnace::quadrature::Rules;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = find(&a[1], ModelOptions::default()).unwrap();
    let n: usize = a[2].parse().unwrap();
    let order: usize = a[3].parse().unwrap();
    let rules = Rules::new(order);
    let t = std::time::Instant::now();
    let mut s = 0.0;
    let dims = m.axes().len();
    let cells = n.pow(dims as u32);
    for c in 0..cells {
        let mut x = vec![0.0; dims];
        let mut k = c;
        for d in (0..dims).rev() { let i = k % n; k /= n; let ax = &m.axes()[d]; x[d] = ax.default_range.0 + (ax.default_range.1-ax.default_range.0) * i as f64 / (n-1) as f64; }
        s += m.integrate(&x, &rules)[0];
    }
    let dt = t.elapsed().as_secs_f64();
    println!("{} cells, {:.2} us/cell, sum {s}", cells, dt / cells as f64 * 1e6);
}
