//! Number and point formatting of the report's markdown.

use crate::report::plot::{self};

/// `{:.2e}`, or "–" for a non-finite value.
pub fn fmt_e(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2e}")
    } else {
        "–".into()
    }
}

/// `{:.4}`, or "–".
pub fn fmt_f(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.4}")
    } else {
        "–".into()
    }
}

/// "r = 0.5, μ = 0.25".
pub(super) fn fmt_point(x: &[f64], axes: &[String]) -> String {
    let names: Vec<String> = if axes.len() == x.len() {
        axes.to_vec()
    } else if x.len() == 3 {
        vec!["f0".into(), "r".into(), "mu".into()]
    } else {
        vec!["r".into(), "mu".into()]
    };
    x.iter()
        .zip(names)
        .map(|(v, n)| {
            format!(
                "{} = {}",
                if n == "mu" { "μ".to_string() } else { n },
                plot::format_number(*v)
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}
