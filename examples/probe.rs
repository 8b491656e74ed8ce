use furnace::bsdf::find;
use furnace::quadrature::Rules;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = find(&a[1]).unwrap();
    let x: Vec<f64> = a[2].split(',').map(|v| v.parse().unwrap()).collect();
    let refv = m.integrate(&x, &Rules::new(256));
    println!("ref {:.15} {:.15} {:.15}", refv[0], refv[1], refv[2]);
    for (o, i) in [(8, 8), (16, 16), (16, 64), (64, 16), (32, 32), (24, 24)] {
        let v = m.integrate(&x, &Rules::with_orders(o, i));
        println!(
            "{o:4} {i:4} {:.3e} {:.3e} {:.3e}",
            v[0] - refv[0],
            v[1] - refv[1],
            v[2] - refv[2]
        );
    }
}
