use furnace::bsdf::find;
use furnace::quadrature::Rules;
use rayon::prelude::*;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = find(&a[1]).unwrap();
    let n: usize = a[2].parse().unwrap();
    let (o1, o2): (usize, usize) = (a[3].parse().unwrap(), a[4].parse().unwrap());
    let (r1, r2) = (Rules::new(o1), Rules::new(o2));
    let dims = m.axes().len();
    let cells = n.pow(dims as u32);
    let t = std::time::Instant::now();
    let res: Vec<(f64, Vec<f64>, [f64; 3])> = (0..cells)
        .into_par_iter()
        .map(|c| {
            let mut x = vec![0.0; dims];
            let mut k = c;
            for d in (0..dims).rev() {
                let i = k % n;
                k /= n;
                let ax = &m.axes()[d];
                x[d] = ax.default_range.0
                    + (ax.default_range.1 - ax.default_range.0) * i as f64 / (n - 1) as f64;
            }
            let v1 = m.integrate(&x, &r1);
            let v2 = m.integrate(&x, &r2);
            let d = (0..3).map(|i| (v1[i] - v2[i]).abs()).fold(0.0, f64::max);
            (d, x, v2)
        })
        .collect();
    let mut sorted = res.clone();
    sorted.sort_by(|a, b| b.0.total_cmp(&a.0));
    println!(
        "{} cells in {:.1}s; max diff {:.2e}",
        cells,
        t.elapsed().as_secs_f64(),
        sorted[0].0
    );
    for r in sorted.iter().take(6) {
        println!("  {:.2e} at {:?} -> {:?}", r.0, r.1, r.2);
    }
    for th in [1e-6, 1e-7, 1e-8, 1e-9] {
        let bad = res.iter().filter(|r| r.0 > th).count();
        println!(
            "cells with diff > {th:e}: {bad} ({:.1}%)",
            100.0 * bad as f64 / cells as f64
        );
    }
}
