//! Energy-compensation helpers emitted next to the albedo functions, after Sforza & Pellacini
//! 2022, "Enforcing Energy Preservation in Microfacet Models" (cited as "the paper"). Each is a
//! tiny function that calls an emitted albedo, so a renderer gets the factor it multiplies by:
//!
//! * conductor: Turquin's scale 1 + F0·(1 − E)/E (paper eq. 13, after Turquin 2019): the single-
//!   scattering BRDF times it is ρ_ss + ρ_ms; and 1/E, the normalisation of a thin dielectric
//!   (paper §3.4 with eq. 19 on the conductor table) and of the glossy specular layer ρ_ss/E_ss
//!   (paper eq. 18);
//! * glossy: the diffuse weight 1 − E_spec (paper eq. 18);
//! * dielectric: the normalisation 1/E (paper eq. 19), and — when the entering and leaving fits
//!   are emitted together — the choice of table by the side of the surface ωo is on: the
//!   entering table (relative IOR η) when n·ωo ≥ 0, the leaving one (1/η) otherwise, at
//!   μ = |n·ωo| (paper §3.3, "it is necessary to store two tables").

use super::generate::{ident, ALBEDO_FLOOR};
use super::ir::build::*;
use super::ir::{Function, Stmt};
use crate::bsdf::{Family, ModelId, Side};

/// An emitted albedo function the helpers can call.
#[derive(Clone, Debug)]
pub struct AlbedoRef {
    /// The model as the fit file names it.
    pub model: String,
    /// Its registered identity (None for a table furnace did not make).
    pub id: Option<ModelId>,
    pub function: String,
    pub params: Vec<String>,
}

fn call_albedo(a: &AlbedoRef) -> super::ir::Expr {
    call(&a.function, a.params.iter().map(|p| var(p)).collect())
}

fn floor_stmt(value: super::ir::Expr) -> Stmt {
    Stmt {
        name: "e".into(),
        value: max(value, lit(ALBEDO_FLOOR)),
        comment: Some(format!("guard: the albedo is clamped to [0, 1]; {ALBEDO_FLOOR} keeps 1/E finite (these albedos stay far above it)")),
    }
}

/// `1/max(E, floor)` for the albedo `a`.
fn normalization(name: String, a: &AlbedoRef, doc: Vec<String>) -> Function {
    Function {
        name,
        doc,
        params: a.params.clone(),
        body: vec![floor_stmt(call_albedo(a))],
        result: div(lit(1.0), var("e")),
    }
}

/// The helpers for the albedo functions of one emitted file, in call order.
pub fn helpers(albedos: &[AlbedoRef]) -> Vec<Function> {
    let mut out = Vec::new();
    for a in albedos {
        let prefix = ident(&a.model);
        let args = a.params.join(", ");
        let Some(id) = a.id else { continue };
        match id.family {
            Family::GGX_CONDUCTOR => {
                let mut params = vec!["f0".to_string()];
                params.extend(a.params.iter().filter(|p| *p != "f0").cloned());
                out.push(Function {
                    name: format!("{prefix}_turquin_scale"),
                    doc: vec![
                        format!("Turquin's multiple-scattering scale 1 + F0·(1 − E)/E with E = {}({args}):", a.function),
                        "multiply the single-scattering conductor BRDF by it (Sforza & Pellacini 2022, eq. 13;".into(),
                        "Turquin 2019). F0 is the normal-incidence reflectance: call once per colour channel.".into(),
                    ],
                    params,
                    body: vec![floor_stmt(call_albedo(a))],
                    result: add(lit(1.0), mul(var("f0"), div(sub(lit(1.0), var("e")), var("e")))), // paper eq. 13
                });
                out.push(normalization(
                    format!("{prefix}_normalization"),
                    a,
                    vec![
                        format!("1/E with E = {}({args}): divide a thin dielectric's reflection + transmission by E", a.function),
                        "(Sforza & Pellacini 2022, §3.4 with eq. 19), or the glossy specular layer ρ_ss/E_ss (eq. 18).".into(),
                    ],
                ));
            }
            Family::GGX_GLOSSY => out.push(Function {
                name: format!("{prefix}_diffuse_weight"),
                doc: vec![
                    format!("Weight 1 − E_spec of the diffuse base under the specular layer, E_spec = {}({args})", a.function),
                    "(Sforza & Pellacini 2022, eq. 18: ρ = ρ_ss/E_ss + (1 − E_spec) ρ_diff).".into(),
                ],
                params: a.params.clone(),
                body: vec![],
                result: sub(lit(1.0), call_albedo(a)), // paper eq. 18
            }),
            Family::GGX_DIELECTRIC => out.push(normalization(
                format!("{prefix}_normalization"),
                a,
                vec![
                    format!("1/E with E = {}({args}): divide the single-scattering BSDF ρ_R + ρ_T by it", a.function),
                    "(Sforza & Pellacini 2022, eq. 19).".into(),
                ],
            )),
            _ => {}
        }
    }
    out.extend(sided(albedos));
    out
}

/// The side-of-surface helpers for every (entering, leaving) dielectric pair with the same
/// Smith form and a `mu` argument.
fn sided(albedos: &[AlbedoRef]) -> Vec<Function> {
    let mut out = Vec::new();
    for enter in albedos {
        let Some(enter_id) = enter.id else { continue };
        if enter_id.family != Family::GGX_DIELECTRIC || enter_id.side != Some(Side::Entering) {
            continue;
        }
        let leave_id = enter_id.with_side(Side::Leaving);
        let Some(leave) = albedos
            .iter()
            .find(|a| a.id == Some(leave_id) && a.params == enter.params)
        else {
            continue;
        };
        if !enter.params.iter().any(|p| p == "mu") {
            continue;
        }
        let prefix = ident(&enter.model);
        let params: Vec<String> = enter
            .params
            .iter()
            .map(|p| {
                if p == "mu" {
                    "cos_o".to_string()
                } else {
                    p.clone()
                }
            })
            .collect();
        let args = |mu: super::ir::Expr, a: &AlbedoRef| {
            call(
                &a.function,
                a.params
                    .iter()
                    .map(|p| if p == "mu" { mu.clone() } else { var(p) })
                    .collect(),
            )
        };
        let albedo_name = format!("{prefix}_sided_albedo");
        out.push(Function {
            name: albedo_name.clone(),
            doc: vec![
                format!("E of the dielectric seen from ωo, cos_o = n·ωo: {}(…, cos_o) when ωo is on the side the", enter.function),
                format!("normal points to (entering, relative IOR η), else {}(…, −cos_o) (leaving, 1/η)", leave.function),
                "(Sforza & Pellacini 2022, §3.3: one table per direction of travel).".into(),
            ],
            params: params.clone(),
            body: vec![],
            result: select_ge(var("cos_o"), lit(0.0), args(var("cos_o"), enter), args(sub(lit(0.0), var("cos_o")), leave)),
        });
        let sided_ref = AlbedoRef {
            model: enter.model.clone(),
            id: enter.id,
            function: albedo_name,
            params,
        };
        out.push(normalization(
            format!("{prefix}_sided_normalization"),
            &sided_ref,
            vec![
                "1/E for the side ωo is on (see the sided albedo above): divide ρ_R + ρ_T by it"
                    .into(),
                "(Sforza & Pellacini 2022, eq. 19).".into(),
            ],
        ));
    }
    out
}
