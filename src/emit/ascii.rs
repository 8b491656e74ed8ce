//! Emitted source is ASCII: shader toolchains and bindings that count bytes as characters (one
//! WGSL binding's string-length handling broke on a `μ` in a comment) get plain text. The
//! documentation the generator writes borrows mathematical notation from the models and
//! papers; [`to_ascii`] spells it out (`μo = n·ωo` → `mu_o = n*w_o`, `≤` → `<=`).

use crate::error::{Error, Result};

/// Spelled-out forms, longest match first (`μo` before `μ`).
const SPELLINGS: &[(&str, &str)] = &[
    ("μo", "mu_o"),
    ("μi", "mu_i"),
    ("ωo", "w_o"),
    ("ωi", "w_i"),
    ("ωm", "w_m"),
    ("ρ_ss", "rho_ss"),
    ("θo", "theta_o"),
    ("θi", "theta_i"),
    ("η²", "eta^2"),
    ("α", "alpha"),
    ("β", "beta"),
    ("γ", "gamma"),
    ("δ", "delta"),
    ("Δ", "delta "),
    ("ε", "eps"),
    ("η", "eta"),
    ("θ", "theta"),
    ("κ", "kappa"),
    ("λ", "lambda"),
    ("Λ", "Lambda"),
    ("μ", "mu"),
    ("π", "pi"),
    ("ρ", "rho"),
    ("σ", "sigma"),
    ("Σ", "sum "),
    ("Π", "prod "),
    ("τ", "tau"),
    ("φ", "phi"),
    ("ω", "w"),
    ("−", "-"),
    ("–", "-"),
    ("—", "--"),
    ("≤", "<="),
    ("≥", ">="),
    ("≠", "!="),
    ("≈", "~"),
    ("±", "+/-"),
    ("×", "x"),
    ("·", "*"),
    ("÷", "/"),
    ("√F0", "sqrt(F0)"),
    ("√(", "sqrt("),
    ("√", "sqrt "),
    ("∞", "inf"),
    ("∫", "integral "),
    ("≡", "=="),
    ("\u{304}", "_bar"),
    ("∈", "in"),
    ("→", "->"),
    ("…", "..."),
    ("§", "section "),
    ("°", " deg"),
    ("²", "^2"),
    ("³", "^3"),
    ("⁻¹", "^-1"),
    ("⁻", "^-"),
    ("⁰", "^0"),
    ("¹", "^1"),
    ("⁴", "^4"),
    ("⁵", "^5"),
    ("⁶", "^6"),
    ("₀", "0"),
    ("₁", "1"),
    ("₂", "2"),
    ("‖", "||"),
    ("“", "\""),
    ("”", "\""),
    ("‘", "'"),
    ("’", "'"),
    ("é", "e"),
    ("è", "e"),
    ("ö", "o"),
    ("ü", "u"),
    ("\u{a0}", " "),
];

/// `text` with every non-ASCII character spelled out; an error names a character with no
/// spelling (a generator change that needs one).
pub fn to_ascii(text: &str) -> Result<String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if c.is_ascii() {
            out.push(c);
            rest = &rest[1..];
            continue;
        }
        match SPELLINGS.iter().find(|(from, _)| rest.starts_with(from)) {
            Some((from, to)) => {
                out.push_str(to);
                rest = &rest[from.len()..];
            }
            None => {
                return Err(Error::InvalidInput(format!(
                    "emitted text must be ASCII and '{c}' (U+{:04X}) has no ASCII spelling (a generator bug; please report it)",
                    c as u32
                )))
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notation_is_spelled_out() {
        assert_eq!(
            to_ascii("μo = n·ωo ∈ [0, 1], α = r² ≤ 1 — §3.3").unwrap(),
            "mu_o = n*w_o in [0, 1], alpha = r^2 <= 1 -- section 3.3"
        );
        assert!(to_ascii("plain").unwrap() == "plain");
        let e = to_ascii("a ☃ b").unwrap_err().to_string();
        assert!(e.contains("U+2603"), "{e}");
    }

    /// Every model's summary and axis descriptions (what headers quote) can be spelled out.
    #[test]
    fn every_model_text_is_spellable() {
        for m in crate::bsdf::models() {
            to_ascii(&m.summary()).unwrap();
            for a in m.axes() {
                to_ascii(&a.description).unwrap();
            }
        }
    }
}
