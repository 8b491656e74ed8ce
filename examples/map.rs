fn main() {
    let a: Vec<f64> = std::env::args().skip(1).map(|v| v.parse().unwrap()).collect();
    let (eta, alpha, mu_o) = (a[0], a[1], a[2]);
    let sin_o = (1.0 - mu_o * mu_o).sqrt();
    let theta_v = (alpha * sin_o).atan2(mu_o);
    let phi_max = std::f64::consts::PI - theta_v;
    let (nb, np) = (40, 100);
    for ib in 0..nb {
        let beta = (ib as f64 + 0.5) / nb as f64 * std::f64::consts::FRAC_PI_2;
        let (sb, cb) = beta.sin_cos();
        let mut s = String::new();
        for ip in 0..np {
            let phi = (ip as f64 + 0.5) / np as f64 * phi_max;
            let (sp, cp) = phi.sin_cos();
            let m = [alpha * cb * cp, alpha * sb, cb * sp];
            let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
            let h = [m[0] / l, m[1] / l, m[2] / l];
            let c = sin_o * h[0] + mu_o * h[2];
            let mu_i = 2.0 * c * h[2] - mu_o;
            let sin2t = (1.0 - c * c) / (eta * eta);
            let ch = if sin2t >= 1.0 {
                if mu_i > 0.0 { 'R' } else { '.' }
            } else {
                let ct = (1.0 - sin2t).sqrt();
                let mt = -mu_o / eta + (c / eta - ct) * h[2];
                match (mu_i > 0.0, mt < 0.0) { (true, true) => 'B', (true, false) => 'r', (false, true) => 't', _ => 'x' }
            };
            s.push(ch);
        }
        println!("{s}");
    }
}
