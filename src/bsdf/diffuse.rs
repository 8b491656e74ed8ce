//! Rough-diffuse models of the Oren–Nayar family, after Portsmouth, Kutz & Hill, "EON: A practical
//! energy-preserving rough diffuse BRDF" (cited below as "EON paper"), all with white
//! single-scattering albedo ρ = 1:
//!
//! * `oren-nayar-qon`: the qualitative Oren–Nayar model (QON, EON paper eqs. 1–4), with the
//!   roughness angle σ = (π/2)·r ([`qon_sigma_from_r`]);
//! * `oren-nayar-fon`: Fujii's Oren–Nayar model (FON, eqs. 10–11), r the paper's interpolation weight;
//! * `eon`: FON plus the energy-compensation lobe (eqs. 16, 19), built on the *exact* FON albedo
//!   (eqs. 12–13, 15), so E = 1 for every r and μ. (The paper also offers a faster variant that
//!   uses the polynomial fit of eq. 14 inside the lobe; that variant is only approximately
//!   energy-preserving and is not a model here — see [`fon_albedo_fit`].)
//!
//! # The integral
//! E(μo) = ∫ f(ωi, ωo) μi dωi is integrated over (μi, φ), φ = φi − φo, with dωi = dμi dφ. Every
//! BRDF here is even in φ, so φ runs over [0, π] and the result is doubled. There
//! s = ωi·ωo − μi μo = sinθi sinθo cos φ (the `s` of EON paper eq. 3).
//!
//! # Terms shared by a column
//! Each BRDF is a sum f = Σ_k c_k(r, μo)·b_k(μi, μo, s) of terms b_k that do not depend on r
//! ([`DiffuseModel::coefficients`], [`diffuse_terms`]): QON and FON are A/π + B·(s/t)/π with
//! (A, B) functions of r alone (EON paper, eqs. 3, 10), and the EON lobe is
//! r a(μo)/((1 + c₁ r)(c₁ − c₂)) · a(μi)/π (eq. 19 at ρ = 1, see [`eon_ms_brdf`]). So
//! E(r, μo) = Σ_k c_k(r, μo) I_k(μo) with I_k = ∫ b_k μi dωi: one quadrature of the terms per μo
//! serves every r, and a table's column along r ([`Model::integrate_column`]) costs one
//! quadrature instead of one per cell. A single point takes the same path, so a cell has the
//! same bits whichever way it is computed.
//!
//! # Kinks
//! s/t changes branch at s = 0, i.e. at φ = π/2 (the cos⁺ of eq. 2, the cases of eqs. 4 and 11),
//! and t = max(μi, μo) changes branch at μi = μo. Both are panel ends: φ ∈ [0, π/2] ∪ [π/2, π]
//! and μi ∈ [0, μo] ∪ [μo, 1]. On every panel the integrand is then smooth except for
//! sinθi = √(1 − μi²) (and, in the EON lobe, acos μi) at μi = 1: a square-root end that the
//! smoothed Gauss–Legendre rule absorbs.
//!
//! # Oracles
//! The closed-form albedos of the paper — [`qon_albedo_analytic`] (eqs. 5, 8),
//! [`fon_albedo_analytic`] (eqs. 12–13), [`eon_albedo_analytic`] (eqs. 16, 20) and the averages
//! [`qon_average_albedo`] (eq. 9), [`fon_average_albedo`] (eq. 15) — are implemented separately
//! from the BRDFs and serve as test oracles; the models themselves integrate the BRDF.

use super::{AxisSpec, Family, Model, ModelId, MAX_OUTPUTS};
use crate::quadrature::{integrate_2d_into, Integrand2D, Rules, CHANNELS};
use std::f64::consts::{FRAC_PI_2, PI};

/// A_q = 1 − 0.5 σ²/(σ² + 0.33): the 0.5 (EON paper, §2.1, below eq. 1).
const QON_A_SCALE: f64 = 0.5;
/// A_q = 1 − 0.5 σ²/(σ² + 0.33): the 0.33 (EON paper, §2.1, below eq. 1).
const QON_A_DAMPING: f64 = 0.33;
/// B_q = 0.45 σ²/(σ² + 0.09): the 0.45 (EON paper, §2.1, below eq. 1).
const QON_B_SCALE: f64 = 0.45;
/// B_q = 0.45 σ²/(σ² + 0.09): the 0.09 (EON paper, §2.1, below eq. 1).
const QON_B_DAMPING: f64 = 0.09;
/// Upper end of the QON roughness angle, σ ∈ [0, π/2] (EON paper, §2.1, below eq. 4).
const QON_SIGMA_MAX: f64 = FRAC_PI_2;
/// 1/2 − 2/(3π): A_F = 1/(1 + c₁ r) (EON paper, §2.2, below eq. 11; `constant1_FON` of Listing 1).
pub const FON_C1: f64 = 0.5 - 2.0 / (3.0 * PI);
/// 2/3 − 28/(15π): ⟨E_F⟩ = A_F (1 + c₂ r) (EON paper, eq. 15; `constant2_FON` of Listing 1).
pub const FON_C2: f64 = 2.0 / 3.0 - 28.0 / (15.0 * PI);
/// 2/3 − 64/(45π): ⟨E_q⟩ = A_q + c B_q (EON paper, eq. 9).
const QON_AVERAGE_C: f64 = 2.0 / 3.0 - 64.0 / (45.0 * PI);
/// g₁ … g₄ of the fit G_F(θ) ≈ π Σ g_k (1 − cos θ)^k (EON paper, eq. 14, table below it).
const FON_FIT_G: [f64; 4] = [0.0571085289, 0.491881867, -0.332181442, 0.0714429953];

/// Which member of the Oren–Nayar family a model is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiffuseKind {
    /// Qualitative Oren–Nayar (EON paper, eqs. 3–4), σ = (π/2) r.
    Qon,
    /// Fujii's Oren–Nayar (EON paper, eqs. 10–11).
    Fon,
    /// Energy-preserving Oren–Nayar: FON + multiple-scattering lobe (EON paper, eqs. 16, 19).
    Eon,
}

/// A rough-diffuse model with white albedo, E(r, μ).
#[derive(Clone, Debug)]
pub struct DiffuseModel {
    pub kind: DiffuseKind,
}

impl DiffuseModel {
    pub fn new(kind: DiffuseKind) -> DiffuseModel {
        DiffuseModel { kind }
    }

    /// The BRDF at roughness axis value `r` (see [`Model::axes`] for what r means per model),
    /// with s = ωi·ωo − μi μo.
    pub fn brdf(&self, r: f64, mu_i: f64, mu_o: f64, s: f64) -> f64 {
        match self.kind {
            DiffuseKind::Qon => qon_brdf(qon_sigma_from_r(r), mu_i, mu_o, s),
            DiffuseKind::Fon => fon_brdf(r, mu_i, mu_o, s),
            DiffuseKind::Eon => eon_brdf(r, mu_i, mu_o, s),
        }
    }

    /// The paper's closed-form albedo of this model (the test oracle).
    pub fn albedo_analytic(&self, r: f64, mu_o: f64) -> f64 {
        match self.kind {
            DiffuseKind::Qon => qon_albedo_analytic(r, mu_o),
            DiffuseKind::Fon => fon_albedo_analytic(r, mu_o),
            DiffuseKind::Eon => eon_albedo_analytic(r, mu_o),
        }
    }

    /// The coefficients c_k(r, μo) of the BRDF's terms, f = Σ_k c_k(r, μo)·b_k(μi, μo, s)
    /// with b_k = [`diffuse_terms`] (module docs, "Terms shared by a column").
    pub fn coefficients(&self, r: f64, mu_o: f64) -> [f64; DIFFUSE_TERMS] {
        match self.kind {
            DiffuseKind::Qon => {
                let (a, b) = qon_coefficients(qon_sigma_from_r(r)); // EON paper, eq. 3
                [a, b, 0.0]
            }
            DiffuseKind::Fon => {
                let (a, b) = fon_coefficients(r); // EON paper, eq. 10
                [a, b, 0.0]
            }
            DiffuseKind::Eon => {
                let (a, b) = fon_coefficients(r);
                // EON paper, eq. 19 at ρ = 1 (see eon_ms_brdf): the lobe's factors but a(μi)
                let ms = r * fon_albedo_complement_per_r(mu_o)
                    / ((1.0 + FON_C1 * r) * (FON_C1 - FON_C2));
                [a, b, ms]
            }
        }
    }

    /// I_k(μo) = ∫ b_k(μi, μo, s) μi dωi of the BRDF's terms, by quadrature with `rules`.
    pub fn term_integrals(&self, mu_o: f64, rules: &Rules) -> [f64; DIFFUSE_TERMS] {
        let mut total = [0.0; DIFFUSE_TERMS];
        integrate_2d_into(&DiffuseIntegrand::new(self.kind, mu_o), rules, &mut total);
        total
    }

    /// E(r, μo) by quadrature of the BRDF with `rules`: Σ_k c_k(r, μo) I_k(μo).
    pub fn albedo(&self, r: f64, mu_o: f64, rules: &Rules) -> f64 {
        combine(
            &self.coefficients(r, mu_o),
            &self.term_integrals(mu_o, rules),
        )
    }
}

/// Number of terms in the split f = Σ_k c_k b_k of a rough-diffuse BRDF.
pub const DIFFUSE_TERMS: usize = 3;

/// Σ_k c_k I_k, in term order.
fn combine(c: &[f64; DIFFUSE_TERMS], integrals: &[f64; DIFFUSE_TERMS]) -> f64 {
    c.iter().zip(integrals).map(|(c, i)| c * i).sum()
}

/// The r-free terms b_k(μi, μo, s) of a rough-diffuse BRDF at ρ = 1 (module docs): 1/π, the
/// s/t term over π (EON paper, eq. 4 for QON, eq. 11 for FON and EON) and, for EON, the lobe's
/// a(μi)/π (eq. 19); f = Σ_k c_k b_k with c_k = [`DiffuseModel::coefficients`].
pub fn diffuse_terms(kind: DiffuseKind, mu_i: f64, mu_o: f64, s: f64) -> [f64; DIFFUSE_TERMS] {
    let s_over_t = match kind {
        DiffuseKind::Qon => qon_s_over_t(mu_i, mu_o, s),
        DiffuseKind::Fon | DiffuseKind::Eon => fon_s_over_t(mu_i, mu_o, s),
    };
    let lobe = match kind {
        DiffuseKind::Eon => fon_albedo_complement_per_r(mu_i) / PI, // EON paper, eq. 19
        DiffuseKind::Qon | DiffuseKind::Fon => 0.0,
    };
    [1.0 / PI, s_over_t / PI, lobe]
}

impl Model for DiffuseModel {
    fn id(&self) -> ModelId {
        ModelId::new(match self.kind {
            DiffuseKind::Qon => Family::OREN_NAYAR_QON,
            DiffuseKind::Fon => Family::OREN_NAYAR_FON,
            DiffuseKind::Eon => Family::EON,
        })
    }

    fn summary(&self) -> String {
        match self.kind {
            DiffuseKind::Qon => "qualitative Oren–Nayar (QON), white albedo, σ = (π/2)·r (EON paper, eqs. 1–4)",
            DiffuseKind::Fon => "Fujii's Oren–Nayar (FON), white albedo (EON paper, eqs. 10–11)",
            DiffuseKind::Eon => {
                "energy-preserving Oren–Nayar (EON): FON + exact-albedo multiple-scattering lobe, white albedo (EON paper, eqs. 16, 19)"
            }
        }
        .to_string()
    }

    fn axes(&self) -> Vec<AxisSpec> {
        let r = match self.kind {
            DiffuseKind::Qon => AxisSpec::new(
                "r",
                (0.0, 1.0),
                (0.0, 1.0),
                "QON roughness as a fraction of its range: the microfacet-slope angle is σ = (π/2)·r radians (σ ∈ [0, π/2])",
            ),
            DiffuseKind::Fon => AxisSpec::new(
                "r",
                (0.0, 1.0),
                (0.0, 1.0),
                "Fujii's roughness weight r: A_F = 1/(1 + (1/2 − 2/(3π)) r), B_F = r A_F (r = 0 is Lambert)",
            ),
            DiffuseKind::Eon => AxisSpec::new(
                "r",
                (0.0, 1.0),
                (0.0, 1.0),
                "EON roughness r, the FON weight: A_F = 1/(1 + (1/2 − 2/(3π)) r), B_F = r A_F (r = 0 is Lambert)",
            ),
        };
        let mu = AxisSpec::new(
            "mu",
            (0.0, 1.0),
            (0.0, 1.0),
            "cosine of the outgoing direction, μo = n·ωo",
        );
        vec![r, mu]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec!["E"]
    }

    fn integrate(&self, x: &[f64], rules: &Rules) -> [f64; MAX_OUTPUTS] {
        [self.albedo(x[0], x[1], rules), 0.0, 0.0]
    }

    /// A column along r at one μo: the terms' integrals once, then Σ_k c_k(r, μo) I_k(μo) per
    /// cell (the same arithmetic as [`DiffuseModel::albedo`], so the same bits).
    fn integrate_column(&self, xs: &[Vec<f64>], rules: &Rules, out: &mut [[f64; MAX_OUTPUTS]]) {
        let Some(first) = xs.first() else {
            return;
        };
        let mu_o = first[1];
        let integrals = self.term_integrals(mu_o, rules);
        for (x, o) in xs.iter().zip(out.iter_mut()) {
            debug_assert_eq!(x[1], mu_o, "a column shares μo");
            *o = [
                combine(&self.coefficients(x[0], mu_o), &integrals),
                0.0,
                0.0,
            ];
        }
    }

    fn shares_column_geometry(&self) -> bool {
        true
    }
}

/// The QON roughness angle σ for the axis value r ∈ [0, 1]: σ = (π/2) r, so that r = 1/2 is the
/// paper's "50% roughness" σ = π/4 (EON paper, Fig. 2 caption; σ ∈ [0, π/2], §2.1).
pub fn qon_sigma_from_r(r: f64) -> f64 {
    QON_SIGMA_MAX * r
}

/// (A_q, B_q) at roughness angle σ (EON paper, §2.1, below eq. 1).
pub fn qon_coefficients(sigma: f64) -> (f64, f64) {
    let s2 = sigma * sigma;
    let a = 1.0 - QON_A_SCALE * s2 / (s2 + QON_A_DAMPING); // EON paper, §2.1 (A_q)
    let b = QON_B_SCALE * s2 / (s2 + QON_B_DAMPING); // EON paper, §2.1 (B_q)
    (a, b)
}

/// (A_F, B_F) at roughness r (EON paper, §2.2, below eq. 11).
pub fn fon_coefficients(r: f64) -> (f64, f64) {
    let a = 1.0 / (1.0 + FON_C1 * r); // EON paper, §2.2 (A_F)
    (a, r * a) // EON paper, §2.2 (B_F = r A_F)
}

/// t = max(μi, μo) (EON paper, eqs. 4 and 11, case s > 0), or `None` when both directions are
/// grazing: there s/t has no limit (it depends on the path), and the point has zero projected
/// measure, so callers drop the s/t term.
fn t_max(mu_i: f64, mu_o: f64) -> Option<f64> {
    let t = mu_i.max(mu_o);
    (t > 0.0).then_some(t)
}

/// QON BRDF at ρ = 1 (EON paper, eqs. 3–4): f = (A_q + B_q s/t_q)/π with s/t_q = 0 for s ≤ 0;
/// `s` = ωi·ωo − μi μo.
pub fn qon_brdf(sigma: f64, mu_i: f64, mu_o: f64, s: f64) -> f64 {
    let (a, b) = qon_coefficients(sigma);
    (a + b * qon_s_over_t(mu_i, mu_o, s)) / PI // EON paper, eq. 3
}

/// QON's s/t_q: s/max(μi, μo) for s > 0, 0 for s ≤ 0 (EON paper, eq. 4).
fn qon_s_over_t(mu_i: f64, mu_o: f64, s: f64) -> f64 {
    match t_max(mu_i, mu_o) {
        Some(t) if s > 0.0 => s / t, // EON paper, eq. 4 (s > 0)
        _ => 0.0,                    // EON paper, eq. 4 (s ≤ 0)
    }
}

/// FON's s/t_F: s/max(μi, μo) for s > 0, s for s ≤ 0 (t_F = 1; EON paper, eq. 11).
fn fon_s_over_t(mu_i: f64, mu_o: f64, s: f64) -> f64 {
    if s <= 0.0 {
        s // EON paper, eq. 11 (s ≤ 0: t_F = 1)
    } else {
        t_max(mu_i, mu_o).map_or(0.0, |t| s / t) // EON paper, eq. 11 (s > 0)
    }
}

/// FON BRDF at ρ = 1 (EON paper, eqs. 10–11): f = (A_F + B_F s/t_F)/π with t_F = 1 for s ≤ 0.
pub fn fon_brdf(r: f64, mu_i: f64, mu_o: f64, s: f64) -> f64 {
    let (a, b) = fon_coefficients(r);
    (a + b * fon_s_over_t(mu_i, mu_o, s)) / PI // EON paper, eq. 10
}

/// 1 − E_F(μ) at ρ = 1, cancellation-free: from eq. 12 with A_F = 1/(1 + c₁ r),
/// 1 − E_F = r (c₁ − G_F(μ)/π) / (1 + c₁ r) (EON paper, eqs. 12–13). Non-negative (FON conserves
/// energy) and exactly 0 at μ = 0, where G_F = π c₁.
fn fon_albedo_complement(r: f64, mu: f64) -> f64 {
    r * fon_albedo_complement_per_r(mu) / (1.0 + FON_C1 * r) // EON paper, eqs. 12–13
}

/// c₁ − G_F(μ)/π: the r-independent factor of 1 − E_F (EON paper, eqs. 12–13).
fn fon_albedo_complement_per_r(mu: f64) -> f64 {
    FON_C1 - g_fon(mu) / PI // EON paper, eqs. 12–13
}

/// EON multiple-scattering lobe at ρ = 1 (EON paper, eq. 19). At ρ = 1 the prefactor
/// ⟨E_F⟩/(1 − ρ(1 − ⟨E_F⟩)) is 1, leaving (1 − E_F(μi))(1 − E_F(μo)) / (π (1 − ⟨E_F⟩)). With
/// 1 − E_F(μ) = r a(μ)/(1 + c₁ r) and 1 − ⟨E_F⟩ = r (c₁ − c₂)/(1 + c₁ r) (eqs. 12, 15), one factor
/// r/(1 + c₁ r) cancels:
/// f_ms = r a(μi) a(μo) / (π (1 + c₁ r)(c₁ − c₂)), a(μ) = c₁ − G_F(μ)/π.
/// This is eq. 19 exactly, finite at r = 0 (where the printed form is 0/0) and without the
/// `max(eps, ·)` clamps of the paper's Listing 1, which add energy (E = 1 + eps at μo = 0).
pub fn eon_ms_brdf(r: f64, mu_i: f64, mu_o: f64) -> f64 {
    let a_i = fon_albedo_complement_per_r(mu_i);
    let a_o = fon_albedo_complement_per_r(mu_o);
    r * a_i * a_o / (PI * (1.0 + FON_C1 * r) * (FON_C1 - FON_C2)) // EON paper, eq. 19 (ρ = 1)
}

/// EON BRDF at ρ = 1 (EON paper, eq. 16): f_EON = f_F + f_F^ms.
pub fn eon_brdf(r: f64, mu_i: f64, mu_o: f64, s: f64) -> f64 {
    fon_brdf(r, mu_i, mu_o, s) + eon_ms_brdf(r, mu_i, mu_o) // EON paper, eq. 16
}

/// G_q(θo) of the QON albedo (EON paper, eq. 8), from μo = cos θo:
/// G_q = sinθ (θ − sinθ cosθ) + (2/3) tanθ (1 − sin³θ).
/// The second term is evaluated as (2/3) sinθ μ (1 + sinθ + sin²θ)/(1 + sinθ), using
/// 1 − sinθ = μ²/(1 + sinθ): equal in exact arithmetic, finite at μ = 0 where the printed form is
/// ∞·0, and giving the paper's grazing limit G_q → π/2 exactly.
pub fn g_qon(mu_o: f64) -> f64 {
    let mu = mu_o.clamp(0.0, 1.0);
    let sin_o = ((1.0 - mu) * (1.0 + mu)).sqrt();
    let theta = mu.acos();
    let tan_term = sin_o * mu * (1.0 + sin_o + sin_o * sin_o) / (1.0 + sin_o); // tanθ (1 − sin³θ)
    sin_o * (theta - sin_o * mu) + 2.0 / 3.0 * tan_term // EON paper, eq. 8
}

/// G_F(θo) = G_q(θo) − (2/3) sin θo (EON paper, eq. 13).
pub fn g_fon(mu_o: f64) -> f64 {
    let mu = mu_o.clamp(0.0, 1.0);
    let sin_o = ((1.0 - mu) * (1.0 + mu)).sqrt();
    g_qon(mu) - 2.0 / 3.0 * sin_o // EON paper, eq. 13
}

/// Closed-form QON albedo at ρ = 1: E_q = A_q + (B_q/π) G_q(θo) (EON paper, eqs. 5, 8),
/// σ = (π/2) r.
pub fn qon_albedo_analytic(r: f64, mu_o: f64) -> f64 {
    let (a, b) = qon_coefficients(qon_sigma_from_r(r));
    a + b / PI * g_qon(mu_o) // EON paper, eq. 5
}

/// Closed-form FON albedo at ρ = 1: E_F = A_F + (B_F/π) G_F(θo) (EON paper, eqs. 12–13).
pub fn fon_albedo_analytic(r: f64, mu_o: f64) -> f64 {
    let (a, b) = fon_coefficients(r);
    a + b / PI * g_fon(mu_o) // EON paper, eq. 12
}

/// Closed-form EON albedo at ρ = 1: E = E_F + E_F^ms (EON paper, eqs. 16, 20). At ρ = 1,
/// 𝓕 = 1 − ⟨E_F⟩ (eq. 18), so eq. 20 gives E_ms = 1 − E_F and E = 1 for every r and μo.
/// (Written out rather than returning 1, so that it is an oracle of eq. 20 and not a constant.)
pub fn eon_albedo_analytic(r: f64, mu_o: f64) -> f64 {
    let e_f = fon_albedo_analytic(r, mu_o);
    // E_ms = 𝓕 (1 − E_F)/(1 − ⟨E_F⟩) with 𝓕 = 1 − ⟨E_F⟩ (EON paper, eqs. 18, 20)
    e_f + fon_albedo_complement(r, mu_o)
}

/// Average QON albedo ⟨E_q⟩ = A_q + (2/3 − 64/(45π)) B_q at ρ = 1 (EON paper, eq. 9).
pub fn qon_average_albedo(r: f64) -> f64 {
    let (a, b) = qon_coefficients(qon_sigma_from_r(r));
    a + QON_AVERAGE_C * b // EON paper, eq. 9
}

/// Average FON albedo ⟨E_F⟩ = A_F + (2/3 − 28/(15π)) B_F at ρ = 1 (EON paper, eq. 15).
pub fn fon_average_albedo(r: f64) -> f64 {
    let (a, b) = fon_coefficients(r);
    a + FON_C2 * b // EON paper, eq. 15
}

/// The paper's polynomial fit of the FON albedo, E_F ≈ A_F (1 + r Σ g_k (1 − μ)^k)
/// (EON paper, eq. 14 in eq. 12; `E_FON_approx` of Listing 1). Not used by the models; kept to
/// measure the fit against the exact albedo (the paper quotes < 0.1 % error).
pub fn fon_albedo_fit(r: f64, mu_o: f64) -> f64 {
    let c = 1.0 - mu_o;
    let g_over_pi = c * (FON_FIT_G[0] + c * (FON_FIT_G[1] + c * (FON_FIT_G[2] + c * FON_FIT_G[3]))); // EON paper, eq. 14
    (1.0 + r * g_over_pi) / (1.0 + FON_C1 * r) // EON paper, eq. 12
}

/// The integrand of the terms' integrals I_k(μo) over (μi, φ), one channel per term (see the
/// module docs); it does not depend on r.
pub struct DiffuseIntegrand {
    kind: DiffuseKind,
    mu_o: f64,
    sin_o: f64,
}

/// Per-line data of [`DiffuseIntegrand`]: one value of μi.
pub struct DiffuseLine {
    mu_i: f64,
    sin_i: f64,
}

impl DiffuseIntegrand {
    pub fn new(kind: DiffuseKind, mu_o: f64) -> DiffuseIntegrand {
        let sin_o = ((1.0 - mu_o) * (1.0 + mu_o)).max(0.0).sqrt();
        DiffuseIntegrand { kind, mu_o, sin_o }
    }

    /// The terms times the measure at (line, φ).
    #[inline]
    fn terms_at(&self, line: &DiffuseLine, phi: f64) -> [f64; DIFFUSE_TERMS] {
        let s = line.sin_i * self.sin_o * phi.cos(); // EON paper, eq. 3: s = ωi·ωo − μi μo
                                                     // ×2: the BRDF is even in φ, so [−π, π] folds onto [0, π]; dωi = dμi dφ
        diffuse_terms(self.kind, line.mu_i, self.mu_o, s).map(|b| 2.0 * b * line.mu_i)
    }
}

impl Integrand2D for DiffuseIntegrand {
    type Line = DiffuseLine;

    fn outer_breaks(&self, out: &mut Vec<f64>) {
        out.extend([0.0, self.mu_o, 1.0]); // t = max(μi, μo) switches at μi = μo
    }

    fn line(&self, mu_i: f64, inner_breaks: &mut Vec<f64>) -> DiffuseLine {
        inner_breaks.extend([0.0, FRAC_PI_2, PI]); // s = sinθi sinθo cos φ changes sign at φ = π/2
        DiffuseLine {
            mu_i,
            sin_i: ((1.0 - mu_i) * (1.0 + mu_i)).max(0.0).sqrt(),
        }
    }

    /// The first two terms (the trait's fixed width); [`Self::accumulate`] adds all of them.
    #[inline]
    fn eval(&self, line: &DiffuseLine, phi: f64) -> [f64; CHANNELS] {
        let t = self.terms_at(line, phi);
        [t[0], t[1]]
    }

    fn channels(&self) -> usize {
        DIFFUSE_TERMS
    }

    #[inline]
    fn accumulate(&self, line: &DiffuseLine, phi: f64, w: f64, acc: &mut [f64]) -> bool {
        let t = self.terms_at(line, phi);
        for (a, t) in acc.iter_mut().zip(t) {
            *a += w * t;
        }
        t.iter().any(|&c| c != 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::UnitRule;

    const R_GRID: [f64; 7] = [0.0, 0.05, 0.25, 0.5, 0.75, 0.95, 1.0];
    const MU_GRID: [f64; 11] = [
        0.0,
        1e-6,
        0.01,
        0.1,
        0.3,
        0.5,
        0.7,
        0.9,
        0.99,
        1.0 - 1e-9,
        1.0,
    ];
    /// Agreement asked of quadrature against the closed forms.
    const ORACLE_TOL: f64 = 1e-9;

    fn models() -> [DiffuseModel; 3] {
        [DiffuseKind::Qon, DiffuseKind::Fon, DiffuseKind::Eon].map(DiffuseModel::new)
    }

    /// max |quadrature − closed form| over the grid, at `order`.
    fn max_oracle_error(model: &DiffuseModel, order: usize) -> f64 {
        let rules = Rules::new(order);
        let mut worst: f64 = 0.0;
        for r in R_GRID {
            for mu in MU_GRID {
                let q = model.albedo(r, mu, &rules);
                let a = model.albedo_analytic(r, mu);
                assert!(
                    q.is_finite() && a.is_finite(),
                    "{:?} r={r} mu={mu}: {q} vs {a}",
                    model.kind
                );
                worst = worst.max((q - a).abs());
            }
        }
        worst
    }

    #[test]
    fn quadrature_matches_closed_form_albedos() {
        for model in models() {
            for order in [16, 32] {
                let err = max_oracle_error(&model, order);
                eprintln!(
                    "{:?} order {order}: max |E_quad − E_analytic| = {err:.3e}",
                    model.kind
                );
                assert!(err <= ORACLE_TOL, "{:?} order {order}: {err:e}", model.kind);
            }
        }
    }

    #[test]
    fn eon_is_white_to_1e9() {
        let model = DiffuseModel::new(DiffuseKind::Eon);
        for order in [16, 32] {
            let rules = Rules::new(order);
            let mut worst: f64 = 0.0;
            for r in R_GRID {
                for mu in MU_GRID {
                    worst = worst.max((model.albedo(r, mu, &rules) - 1.0).abs());
                }
            }
            eprintln!("EON order {order}: max |E − 1| = {worst:.3e}");
            assert!(worst <= ORACLE_TOL, "order {order}: {worst:e}");
        }
    }

    #[test]
    fn eon_closed_form_is_one() {
        for r in R_GRID {
            for mu in MU_GRID {
                let e = eon_albedo_analytic(r, mu);
                assert!((e - 1.0).abs() < 1e-15, "r={r} mu={mu}: {e}");
            }
        }
    }

    /// Eqs. 9 and 15 are the cosine-weighted means of eqs. 5 and 12: check them by 1-D
    /// Gauss–Legendre of the closed forms, ⟨E⟩ = ∫ E(μ) 2μ dμ.
    #[test]
    fn average_albedos_match_mean_of_directional() {
        let rule = UnitRule::gauss_legendre_smoothed(64);
        for r in R_GRID {
            let mean = |e: &dyn Fn(f64) -> f64| -> f64 {
                rule.nodes
                    .iter()
                    .zip(&rule.weights)
                    .map(|(&mu, &w)| w * 2.0 * mu * e(mu))
                    .sum()
            };
            let q = mean(&|mu| qon_albedo_analytic(r, mu));
            let f = mean(&|mu| fon_albedo_analytic(r, mu));
            assert!(
                (q - qon_average_albedo(r)).abs() < 1e-13,
                "QON r={r}: {q} vs {}",
                qon_average_albedo(r)
            );
            assert!(
                (f - fon_average_albedo(r)).abs() < 1e-13,
                "FON r={r}: {f} vs {}",
                fon_average_albedo(r)
            );
        }
    }

    #[test]
    fn closed_forms_have_the_papers_limits() {
        // G_q → π/2 at grazing (EON paper, below eq. 8); E_F(π/2) = 1 (below eq. 13)
        assert!((g_qon(0.0) - FRAC_PI_2).abs() < 1e-15);
        assert_eq!(g_qon(1.0), 0.0);
        for r in R_GRID {
            assert!((fon_albedo_analytic(r, 0.0) - 1.0).abs() < 1e-15, "r={r}");
            // r = 0 is Lambert for all three
            for mu in MU_GRID {
                if r == 0.0 {
                    for m in models() {
                        assert!((m.albedo_analytic(r, mu) - 1.0).abs() < 1e-15);
                    }
                }
                // FON conserves energy, so the EON lobe is non-negative
                assert!(fon_albedo_complement(r, mu) >= 0.0, "r={r} mu={mu}");
            }
        }
    }

    #[test]
    fn brdfs_are_reciprocal_and_continuous_at_s_zero() {
        for m in models() {
            for (mu_i, mu_o, s) in [(0.2, 0.7, 0.3), (0.9, 0.1, -0.05), (0.5, 0.5, 0.6)] {
                let a = m.brdf(0.6, mu_i, mu_o, s);
                let b = m.brdf(0.6, mu_o, mu_i, s);
                assert!((a - b).abs() < 1e-15, "{:?}", m.kind);
            }
            let below = m.brdf(0.6, 0.3, 0.4, -1e-12);
            let above = m.brdf(0.6, 0.3, 0.4, 1e-12);
            assert!((below - above).abs() < 1e-10, "{:?}", m.kind);
            // both directions grazing: finite
            assert!(m.brdf(1.0, 0.0, 0.0, 1.0).is_finite());
        }
    }

    /// The term split reproduces each BRDF as written in the paper (eqs. 3–4, 10–11, 16, 19).
    #[test]
    fn terms_sum_to_the_brdf() {
        for m in models() {
            for r in R_GRID {
                for (mu_i, mu_o, s) in [
                    (0.2, 0.7, 0.3),
                    (0.9, 0.1, -0.05),
                    (0.5, 0.5, 0.6),
                    (0.0, 0.3, 0.0),
                    (1.0, 0.0, 0.0),
                    (0.3, 0.8, -0.4),
                ] {
                    let c = m.coefficients(r, mu_o);
                    let split = combine(&c, &diffuse_terms(m.kind, mu_i, mu_o, s));
                    let direct = m.brdf(r, mu_i, mu_o, s);
                    assert!(
                        (split - direct).abs() <= 4e-16 * direct.abs().max(1.0),
                        "{:?} r={r} ({mu_i}, {mu_o}, {s}): {split} vs {direct}",
                        m.kind
                    );
                }
            }
        }
    }

    /// A column along r gives every cell the bits of the cell computed on its own, and the
    /// closed form to 1e-9.
    #[test]
    fn columns_have_the_bits_of_single_cells() {
        let rules = Rules::new(16);
        for m in models() {
            for mu in [0.0, 0.013, 0.5, 0.97, 1.0] {
                let xs: Vec<Vec<f64>> = R_GRID.iter().map(|&r| vec![r, mu]).collect();
                let mut col = vec![[0.0; MAX_OUTPUTS]; xs.len()];
                m.integrate_column(&xs, &rules, &mut col);
                for (x, c) in xs.iter().zip(&col) {
                    let single = m.integrate(x, &rules);
                    assert_eq!(c[0].to_bits(), single[0].to_bits(), "{:?} {x:?}", m.kind);
                    let exact = m.albedo_analytic(x[0], x[1]);
                    assert!((c[0] - exact).abs() < ORACLE_TOL, "{:?} {x:?}", m.kind);
                }
            }
        }
    }

    /// The paper's fit (eq. 14) against the exact FON albedo: it quotes < 0.1 % error.
    #[test]
    fn fon_fit_is_within_the_quoted_error() {
        let mut worst: f64 = 0.0;
        for i in 0..=1000 {
            let mu = i as f64 / 1000.0;
            let (e, a) = (fon_albedo_fit(1.0, mu), fon_albedo_analytic(1.0, mu));
            worst = worst.max(((e - a) / a).abs());
        }
        eprintln!("FON eq. 14 fit at r = 1: max relative error {worst:.3e}");
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn models_describe_their_axes() {
        for m in models() {
            let axes = m.axes();
            assert_eq!(
                axes.iter().map(|a| a.name.as_str()).collect::<Vec<_>>(),
                ["r", "mu"]
            );
            assert_eq!(m.outputs(), ["E"]);
            let e = m.integrate(&[0.5, 0.5], &Rules::new(16))[0];
            assert!((e - m.albedo_analytic(0.5, 0.5)).abs() < ORACLE_TOL);
        }
    }
}
