//! Energy-compensation helpers emitted next to the albedo functions, after Sforza & Pellacini
//! 2022, "Enforcing Energy Preservation in Microfacet Models" (cited as "the paper"). Each is a
//! tiny function that calls an emitted albedo, so a renderer gets the factor it multiplies by:
//!
//! * conductor: Turquin's scale 1 + F0·(1 − E)/E (paper eq. 13, after Turquin 2019): the single-
//!   scattering BRDF times it is ρ_ss + ρ_ms — per channel, and for an RGB F0 with the albedo
//!   evaluated once; and 1/E, the normalisation of a thin dielectric
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
use crate::bsdf::ModelId;
use crate::material::{self, Helper};

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

/// The names of the functions `helper` adds next to an albedo function of `model`.
pub fn helper_names(model: ModelId, helper: Helper) -> Vec<String> {
    names(&ident(&model.name()), helper)
}

fn names(prefix: &str, helper: Helper) -> Vec<String> {
    match helper {
        Helper::TurquinScale => vec![
            format!("{prefix}_turquin_scale"),
            format!("{prefix}_turquin_scale_rgb"),
        ],
        Helper::Normalization => vec![format!("{prefix}_normalization")],
        Helper::DiffuseWeight => vec![format!("{prefix}_diffuse_weight")],
        Helper::Sided { .. } => vec![
            format!("{prefix}_sided_albedo"),
            format!("{prefix}_sided_normalization"),
        ],
    }
}

/// The doc comment of 1/E: its definition, then what each material that needs it does with it
/// (the uses joined by ", or ").
fn normalization_doc(a: &AlbedoRef, args: &str, purposes: &[Vec<String>]) -> Vec<String> {
    let mut lines = vec![format!("1/E with E = {}({args}):", a.function)];
    let uses: Vec<&Vec<String>> = purposes.iter().filter(|p| !p.is_empty()).collect();
    if uses.is_empty() {
        lines[0].push_str(" divide the lobe whose albedo is E by it");
    }
    for (k, purpose) in uses.iter().enumerate() {
        let last = lines.last_mut().expect("one line at least");
        last.push_str(if k == 0 { " " } else { ", or " });
        last.push_str(&purpose[0]);
        lines.extend(purpose[1..].iter().cloned());
    }
    lines.last_mut().expect("one line at least").push('.');
    lines
}

/// The helpers for the albedo functions of one emitted file, in call order: those the material
/// registry lists for each albedo's model ([`material::helpers_for`]), albedo by albedo, then
/// the side-of-surface pairs. `suffix` ends every helper's name (as it ends the albedo
/// functions').
pub fn helpers(albedos: &[AlbedoRef], suffix: &str) -> Vec<Function> {
    let mut out = Vec::new();
    let mut pairs = Vec::new();
    for a in albedos {
        let Some(id) = a.id else { continue };
        let prefix = ident(&a.model);
        let args = a.params.join(", ");
        for (helper, purposes) in material::helpers_for(id) {
            let name = format!("{}{suffix}", names(&prefix, helper).remove(0));
            match helper {
                Helper::TurquinScale => {
                    let mut params = vec!["f0".to_string()];
                    params.extend(a.params.iter().filter(|p| *p != "f0").cloned());
                    out.push(Function {
                        name,
                        doc: vec![
                            format!("Turquin's multiple-scattering scale 1 + F0·(1 − E)/E with E = {}({args}):", a.function),
                            "multiply the single-scattering conductor BRDF by it (Sforza & Pellacini 2022, eq. 13;".into(),
                            "Turquin 2019). F0 is the normal-incidence reflectance of one colour channel, in [0, 1];".into(),
                            format!("for RGB use {prefix}_turquin_scale_rgb{suffix}, which evaluates the albedo once."),
                        ],
                        params: params.clone(),
                        body: vec![floor_stmt(call_albedo(a))],
                        result: add(lit(1.0), mul(var("f0"), div(sub(lit(1.0), var("e")), var("e")))), // paper eq. 13
                    });
                    let channel = |i: u8| add(lit(1.0), mul(component("f0", i), var("k"))); // paper eq. 13
                    out.push(Function {
                        name: format!("{prefix}_turquin_scale_rgb{suffix}"),
                        doc: vec![
                            format!("Turquin's scale 1 + F0·(1 − E)/E for an RGB F0 (each channel in [0, 1]), E = {}({args})", a.function),
                            format!("evaluated once: channel by channel the same value as {prefix}_turquin_scale{suffix}."),
                        ],
                        params,
                        body: vec![
                            floor_stmt(call_albedo(a)),
                            Stmt {
                                name: "k".into(),
                                value: div(sub(lit(1.0), var("e")), var("e")),
                                comment: Some("(1 − E)/E, shared by the three channels".into()),
                            },
                        ],
                        result: vec3(channel(0), channel(1), channel(2)),
                    });
                }
                Helper::Normalization => {
                    out.push(normalization(name, a, normalization_doc(a, &args, &purposes)))
                }
                Helper::DiffuseWeight => out.push(Function {
                    name,
                    doc: vec![
                        format!("Weight 1 − E_spec of the diffuse base under the specular layer, E_spec = {}({args})", a.function),
                        "(Sforza & Pellacini 2022, eq. 18: ρ = ρ_ss/E_ss + (1 − E_spec) ρ_diff).".into(),
                    ],
                    params: a.params.clone(),
                    body: vec![],
                    result: sub(lit(1.0), call_albedo(a)), // paper eq. 18
                }),
                Helper::Sided { leaving } => pairs.push((a, leaving)),
            }
        }
    }
    for (enter, leaving) in pairs {
        out.extend(sided(albedos, enter, leaving, suffix));
    }
    out
}

/// The side-of-surface helpers of the entering albedo `enter` and the albedo of model `leaving`
/// with the same arguments, if it is emitted too and they take `mu`.
fn sided(
    albedos: &[AlbedoRef],
    enter: &AlbedoRef,
    leaving: ModelId,
    suffix: &str,
) -> Vec<Function> {
    let Some(leave) = albedos
        .iter()
        .find(|a| a.id == Some(leaving) && a.params == enter.params)
    else {
        return vec![];
    };
    if !enter.params.iter().any(|p| p == "mu") {
        return vec![];
    }
    let mut out = Vec::new();
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
    let albedo_name = format!("{prefix}_sided_albedo{suffix}");
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
        format!("{prefix}_sided_normalization{suffix}"),
        &sided_ref,
        vec![
            "1/E for the side ωo is on (see the sided albedo above): divide ρ_R + ρ_T by it".into(),
            "(Sforza & Pellacini 2022, eq. 19).".into(),
        ],
    ));
    out
}
