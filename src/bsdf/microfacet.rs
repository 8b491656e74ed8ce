//! What a GGX microfacet integrand carries and the floors on α and μo below which a cell is
//! integrated at its limit: shared by the slope-space ([`super::slope`]) and visible-normal
//! ([`super::vndf`]) integrands and the models built on them ([`super::ggx`]).

/// Smallest α the GGX integrands integrate as given (r = 1e-50). Below it α² heads for
/// underflow (the separable weight 2/(μo + a(μo)) then divided by zero at μo = 0 and gave E = 2)
/// and the slope integrand's s = asinh(ρ/α) for the range of its node exponential, so α is
/// raised to it. The albedo depends on α only through μo/α as α → 0 (and is 1 − O(α), or the
/// smooth interface's, away from μo = 0), so this changes E by less than 1e-90 except for μo
/// within ~1e-100 of 0, where E is its α → 0 limit.
pub(crate) const ALPHA_MIN: f64 = 1e-100;

/// μo below this fraction of α is integrated as μo = 0: E depends on μo/α there and is within
/// ~1e-16 of its grazing limit, while products such as μo·α would leave the normal range.
pub(crate) const GRAZING_RATIO: f64 = 1e-16;

/// The lobes a microfacet integrand carries in its two channels.
#[derive(Clone, Copy, Debug)]
pub enum Lobes {
    /// [E, 0], F = 1.
    Conductor,
    /// [E_R, E_T] for relative IOR `eta`.
    Dielectric { eta: f64 },
    /// [E_R with Fresnel, E_R with F = 1].
    Glossy { eta: f64 },
}
