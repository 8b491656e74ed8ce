use furnace::bsdf::{find, ModelOptions};
use furnace::quadrature::Rules;
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let m = find(&a[1], ModelOptions::default()).unwrap();
    for x in a[2..].iter() {
        let x: Vec<f64> = x.split(',').map(|v| v.parse().unwrap()).collect();
        let refv = m.integrate(&x, &Rules::new(64));
        print!("{:?}: ", x);
        for (o, i) in [(9,9),(12,12),(6,12),(8,12),(12,6),(12,8),(9,12),(12,9)] {
            let v = m.integrate(&x, &Rules::with_orders(o, i));
            print!(" {o}/{i}:{:.1e}", (v[0]-refv[0]).abs());
        }
        println!();
    }
}
