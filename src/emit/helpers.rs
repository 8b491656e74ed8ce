//! Energy-compensation helpers emitted next to the albedo functions, after Sforza & Pellacini
//! 2022, "Enforcing Energy Preservation in Microfacet Models" (cited as "the paper"). Each is a
//! tiny function that calls an emitted albedo, so a renderer gets the factor it multiplies by:
//!
//! * conductor: Turquin's scale 1 + F0·(1 − E)/E (paper eq. 13, after Turquin 2019): the single-
//!   scattering BRDF times it is ρ_ss + ρ_ms — per channel, and for an RGB F0 with the albedo
//!   evaluated once; and 1/E, the normalisation of a thin dielectric
//!   (paper §3.4 with eq. 19 on the conductor table) and of the glossy specular layer ρ_ss/E_ss
//!   (paper eq. 18);
//! * conductor: Kulla & Conty's multiple-scattering lobe (1 − E(μo))(1 − E(μi))/(π(1 − E_avg)),
//!   its colour F_ms = F_avg² E_avg/(1 − F_avg(1 − E_avg)) and the weight of a diffuse base under
//!   a dielectric layer, 1 − (F_avg E + F_ms (1 − E)) (Kulla & Conty 2017, "Revisiting Physically
//!   Based Shading at Imageworks"; the layered form as in Energy Compensation Pt. 1);
//! * glossy: the diffuse weight 1 − E_spec (paper eq. 18);
//! * dielectric: the normalisation 1/E (paper eq. 19), and — when the entering and leaving fits
//!   are emitted together — the choice of table by the side of the surface ωo is on: the
//!   entering table (relative IOR η) when n·ωo ≥ 0, the leaving one (1/η) otherwise, at
//!   μ = |n·ωo| (paper §3.3, "it is necessary to store two tables"); and with the same pair,
//!   Kulla & Conty's multiple-scattering lobes of the rough interface in reflection and
//!   transmission from either side, with their reciprocal energy split (Kulla & Conty 2017; the
//!   derivation in [`crate::material::kulla_conty_dielectric`]).

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
        Helper::KullaConty => vec![
            format!("{prefix}_kulla_conty_lobe"),
            format!("{prefix}_kulla_conty_color"),
            format!("{prefix}_kulla_conty_color_rgb"),
            format!("{prefix}_kulla_conty_diffuse_weight"),
        ],
        Helper::Normalization => vec![format!("{prefix}_normalization")],
        Helper::DiffuseWeight => vec![format!("{prefix}_diffuse_weight")],
        Helper::Sided { .. } => vec![
            format!("{prefix}_sided_albedo"),
            format!("{prefix}_sided_normalization"),
        ],
        Helper::TangentFrameTurquin => vec![
            format!("{prefix}_direction_albedo"),
            format!("{prefix}_turquin_scale"),
            format!("{prefix}_turquin_scale_rgb"),
        ],
        Helper::KullaContyDielectric { .. } => vec![
            format!("{prefix}_kulla_conty_split"),
            format!("{prefix}_kulla_conty_transmission"),
            format!("{prefix}_kulla_conty_bsdf"),
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
    let mut glass = Vec::new();
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
                Helper::KullaConty => out.extend(kulla_conty(a, &prefix, suffix)),
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
                Helper::TangentFrameTurquin => out.extend(tangent_frame(a, &prefix, suffix)),
                Helper::KullaContyDielectric { leaving } => glass.push((a, leaving)),
            }
        }
    }
    for (enter, leaving) in pairs {
        out.extend(sided(albedos, enter, leaving, suffix));
    }
    for (enter, leaving) in glass {
        out.extend(kulla_conty_dielectric(albedos, enter, leaving, suffix));
    }
    out
}

/// Coefficients a_0 … a_16 (even powers) of Abramowitz & Stegun 1964, eq. 4.4.49:
/// atan(t) = t·(a_0 + a_2 t² + … + a_16 t¹⁶) + ε(t) on 0 ≤ t ≤ 1, |ε| ≤ 2e-8 (1.4e-8 measured on
/// 10⁵ points; the test below).
pub const ATAN_COEFFICIENTS: [f64; 9] = [
    1.0,
    -0.333_331_452_8,
    0.199_935_508_5,
    -0.142_088_994_4,
    0.106_562_639_3,
    -0.075_289_640_0,
    0.042_909_613_8,
    -0.016_165_736_7,
    0.002_866_225_7,
];

/// Smallest max(|ωo·t|, |ωo·b|) the azimuth divides by: at normal incidence both vanish, the
/// quotient is then 0 and φ = 0 (E does not depend on φ at μ = 1).
pub const AZIMUTH_FLOOR: f64 = 1e-30;

/// The helpers of an albedo over (…, mu, phi) that take the view direction `wo` in the tangent
/// frame (x along the tangent, y along the bitangent, z along the normal; unit length):
/// E at that direction, and Turquin's scale from it (scalar and RGB F0). μ = wo.z (the albedo
/// clamps it to [0, 1]); φ = atan2(|wo.y|, |wo.x|) ∈ [0, π/2], which is the azimuth reduced by
/// the mirror symmetries E(φ) = E(−φ) = E(π − φ) (docs/anisotropy.md), with the arctangent of
/// Abramowitz & Stegun eq. 4.4.49 on the quotient of the smaller by the larger component, so the
/// same f32 operations run in every language.
fn tangent_frame(a: &AlbedoRef, prefix: &str, suffix: &str) -> Vec<Function> {
    if !(a.params.iter().any(|p| p == "mu") && a.params.iter().any(|p| p == "phi")) {
        return vec![];
    }
    let others: Vec<String> = a
        .params
        .iter()
        .filter(|p| *p != "mu" && *p != "phi")
        .cloned()
        .collect();
    let mut params = others.clone();
    params.push("wo".into());
    let abs = |e: super::ir::Expr| max(e.clone(), sub(lit(0.0), e));
    // Horner in t² (Abramowitz & Stegun 1964, eq. 4.4.49)
    let mut poly = lit(ATAN_COEFFICIENTS[8]);
    for &c in ATAN_COEFFICIENTS[..8].iter().rev() {
        poly = add(mul(poly, var("t2")), lit(c));
    }
    let stmt = |name: &str, value, comment: Option<&str>| Stmt {
        name: name.into(),
        value,
        comment: comment.map(str::to_string),
    };
    // φ from wo, the same statements in each function (the IR passes no vectors to calls)
    let angles = vec![
        stmt("ax", abs(component("wo", 0)), Some("|ωo·t| and |ωo·b|: the mirror images t → −t, b → −b leave E unchanged")),
        stmt("ay", abs(component("wo", 1)), None),
        stmt(
            "t",
            div(min(var("ax"), var("ay")), max(max(var("ax"), var("ay")), lit(AZIMUTH_FLOOR))),
            Some("tan of the angle to the nearer axis, in [0, 1]; guard: 0 at normal incidence, where E does not depend on φ"),
        ),
        stmt("t2", mul(var("t"), var("t")), None),
        stmt("a", mul(var("t"), poly), Some("atan(t) (Abramowitz & Stegun 1964, eq. 4.4.49)")),
        stmt(
            "phi",
            select_ge(var("ax"), var("ay"), var("a"), sub(lit(std::f64::consts::FRAC_PI_2), var("a"))),
            Some("atan2(|ωo·b|, |ωo·t|) in [0, π/2]"),
        ),
    ];
    let e_at = call(
        &a.function,
        a.params
            .iter()
            .map(|p| match p.as_str() {
                "mu" => component("wo", 2),
                _ => var(p),
            })
            .collect(),
    );
    let direction_name = format!("{prefix}_direction_albedo{suffix}");
    let direction = Function {
        name: direction_name.clone(),
        doc: vec![
            format!("E = {}({}) at the view direction wo in the tangent frame: wo.x along the", a.function, a.params.join(", ")),
            "tangent, wo.y along the bitangent, wo.z along the normal, unit length. mu = wo.z; phi = atan2(|wo.y|, |wo.x|)".into(),
            "in [0, π/2], the azimuth reduced by the mirror symmetries E(φ) = E(−φ) = E(π − φ), so any azimuth and".into(),
            "either orientation of the tangent give the same E (arctangent: Abramowitz & Stegun 1964, eq. 4.4.49, |error| ≤ 2e-8).".into(),
        ],
        params: params.clone(),
        body: angles.clone(),
        result: e_at.clone(),
    };
    let with_e = |extra: Vec<Stmt>| {
        let mut body = angles.clone();
        body.push(floor_stmt(e_at.clone()));
        body.extend(extra);
        body
    };
    let mut turquin_params = vec!["f0".to_string()];
    turquin_params.extend(params.iter().cloned());
    let scalar_name = format!("{prefix}_turquin_scale{suffix}");
    let args = params.join(", ");
    let scalar = Function {
        name: scalar_name.clone(),
        doc: vec![
            format!("Turquin's multiple-scattering scale 1 + F0·(1 − E)/E with E = {direction_name}({args}):"),
            "multiply the single-scattering anisotropic conductor BRDF by it (Sforza & Pellacini 2022, eq. 13; Turquin 2019).".into(),
            "F0 is the normal-incidence reflectance of one colour channel, in [0, 1]; wo is the view direction in the".into(),
            format!("tangent frame, unit length. For RGB use {prefix}_turquin_scale_rgb{suffix}, which evaluates the albedo once."),
        ],
        params: turquin_params.clone(),
        body: with_e(vec![]),
        result: add(lit(1.0), mul(var("f0"), div(sub(lit(1.0), var("e")), var("e")))), // paper eq. 13
    };
    let channel = |i: u8| add(lit(1.0), mul(component("f0", i), var("k"))); // paper eq. 13
    let rgb = Function {
        name: format!("{prefix}_turquin_scale_rgb{suffix}"),
        doc: vec![
            format!("Turquin's scale 1 + F0·(1 − E)/E for an RGB F0 (each channel in [0, 1]), E = {direction_name}({args})"),
            format!("evaluated once: channel by channel the same value as {scalar_name}."),
        ],
        params: turquin_params,
        body: with_e(vec![Stmt {
            name: "k".into(),
            value: div(sub(lit(1.0), var("e")), var("e")),
            comment: Some("(1 − E)/E, shared by the three channels".into()),
        }]),
        result: vec3(channel(0), channel(1), channel(2)),
    };
    vec![direction, scalar, rgb]
}

/// Below this 1 − E_avg the Kulla–Conty lobe is off: the average energy it would restore is
/// under 1e-6 (GGX at r ≲ 1e-3), while dividing by it would amplify a fit's error.
pub const KULLA_CONTY_FLOOR: f64 = 1e-6;

/// The Kulla–Conty helpers of albedo `a` (Kulla & Conty 2017, "Revisiting Physically Based
/// Shading at Imageworks"; Kelemen & Szirmay-Kalos 2001), if it takes `mu`: the lobe, its colour
/// (scalar and RGB) and the weight of a diffuse base under a dielectric layer (the layered model
/// of the seed's "Complete Approximate Model", with Kulla & Conty's F_ms).
fn kulla_conty(a: &AlbedoRef, prefix: &str, suffix: &str) -> Vec<Function> {
    if !a.params.iter().any(|p| p == "mu") {
        return vec![];
    }
    let at = |mu: &str| {
        call(
            &a.function,
            a.params
                .iter()
                .map(|p| if p == "mu" { var(mu) } else { var(p) })
                .collect(),
        )
    };
    let others = a.params.iter().filter(|p| *p != "mu").cloned();
    let mut lobe_params = vec!["e_avg".to_string()];
    lobe_params.extend(others.clone());
    lobe_params.extend(["mu_o".to_string(), "mu_i".to_string()]);
    let lobe = Function {
        name: format!("{prefix}_kulla_conty_lobe{suffix}"),
        doc: vec![
            format!("Kulla & Conty's multiple-scattering lobe f_ms = (1 − E(μo))(1 − E(μi)) / (π(1 − E_avg)), E = {}", a.function),
            "at mu_o = n·ωo and mu_i = n·ωi (Kulla & Conty 2017, \"Revisiting Physically Based Shading at".into(),
            "Imageworks\"; Kelemen & Szirmay-Kalos 2001). Add it, times the colour F_ms, to the single-scattering".into(),
            "BRDF; it integrates to 1 − E(μo), so a white conductor keeps all its energy. e_avg is".into(),
            format!("E_avg = 2 ∫ E(μ) μ dμ over [0, 1] at the same roughness: the fit or LUT of the `-avg` model. Returns 0 where 1 − E_avg < {KULLA_CONTY_FLOOR:e}."),
        ],
        params: lobe_params,
        body: vec![
            Stmt { name: "e_o".into(), value: at("mu_o"), comment: None },
            Stmt { name: "e_i".into(), value: at("mu_i"), comment: None },
            Stmt {
                name: "one_minus_e_avg".into(),
                value: sub(lit(1.0), var("e_avg")),
                comment: Some(format!("guard: below {KULLA_CONTY_FLOOR:e} the lobe is off (it would restore less than that)")),
            },
        ],
        result: select_ge(
            var("one_minus_e_avg"),
            lit(KULLA_CONTY_FLOOR),
            div(
                mul(sub(lit(1.0), var("e_o")), sub(lit(1.0), var("e_i"))),
                mul(lit(std::f64::consts::PI), var("one_minus_e_avg")),
            ), // Kulla & Conty 2017, f_ms
            lit(0.0),
        ),
    };
    let color_name = format!("{prefix}_kulla_conty_color{suffix}");
    // Kulla & Conty 2017: F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)), the sum over the bounces
    let f_ms = |f: super::ir::Expr| {
        div(
            mul(mul(f.clone(), f.clone()), var("e_avg")),
            max(
                sub(lit(1.0), mul(f, sub(lit(1.0), var("e_avg")))),
                lit(ALBEDO_FLOOR),
            ),
        )
    };
    let color = Function {
        name: color_name.clone(),
        doc: vec![
            "Kulla & Conty's colour of the multiple-scattering lobe, F_ms = F_avg² E_avg / (1 − F_avg(1 − E_avg)):".into(),
            "multiply the lobe by it. f_avg = 2 ∫ F(μ) μ dμ over [0, 1] of one colour channel's Fresnel (the `fresnel-*` models;".into(),
            format!("F0 + (1 − F0)/21 for Schlick's), e_avg as for {prefix}_kulla_conty_lobe{suffix}."),
        ],
        params: vec!["f_avg".into(), "e_avg".into()],
        body: vec![],
        result: f_ms(var("f_avg")),
    };
    let color_rgb = Function {
        name: format!("{prefix}_kulla_conty_color_rgb{suffix}"),
        doc: vec![format!(
            "F_ms of {color_name} for an RGB F_avg, channel by channel the same value."
        )],
        params: vec!["f_avg".into(), "e_avg".into()],
        body: vec![],
        result: vec3(
            f_ms(component("f_avg", 0)),
            f_ms(component("f_avg", 1)),
            f_ms(component("f_avg", 2)),
        ),
    };
    let mut weight_params = vec!["f_avg".to_string(), "e_avg".to_string()];
    weight_params.extend(a.params.iter().cloned());
    let weight = Function {
        name: format!("{prefix}_kulla_conty_diffuse_weight{suffix}"),
        doc: vec![
            format!("Weight 1 − (F_avg E(μo) + F_ms (1 − E(μo))) of a diffuse base under a dielectric specular layer, E = {}:", a.function),
            "the energy the layer's single scattering (≈ F_avg E) and Kulla–Conty lobe (F_ms (1 − E)) leave to it".into(),
            "(Kulla & Conty 2017, F_avg and F_ms; the layered model of Energy Compensation Pt. 1, \"Complete".into(),
            "Approximate Model\"). f_avg of the dielectric's Fresnel (the `fresnel-dielectric` model), e_avg as above.".into(),
        ],
        params: weight_params,
        body: vec![
            Stmt { name: "e".into(), value: call_albedo(a), comment: None },
            Stmt {
                name: "f_ms".into(),
                value: call(&color_name, vec![var("f_avg"), var("e_avg")]),
                comment: None,
            },
        ],
        result: max(
            sub(
                lit(1.0),
                add(mul(var("f_avg"), var("e")), mul(var("f_ms"), sub(lit(1.0), var("e")))),
            ),
            lit(0.0),
        ),
    };
    vec![lobe, color, color_rgb, weight]
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

/// The Kulla–Conty helpers of a rough dielectric interface (Kulla & Conty 2017, "Revisiting
/// Physically Based Shading at Imageworks", the dielectric slides; derivation and furnace test in
/// [`crate::material::kulla_conty_dielectric`]), when the entering albedo `enter` and the
/// `leaving` one are emitted together with the side-of-surface albedo they call: the reciprocity
/// factor x, the share t of the lost energy transmitted from ωo's side, and the lobe for any
/// pair of directions.
fn kulla_conty_dielectric(
    albedos: &[AlbedoRef],
    enter: &AlbedoRef,
    leaving: ModelId,
    suffix: &str,
) -> Vec<Function> {
    let paired = albedos
        .iter()
        .any(|a| a.id == Some(leaving) && a.params == enter.params);
    let has = |p: &str| enter.params.iter().any(|q| q == p);
    if !paired || !has("mu") || !has("f0") {
        return vec![];
    }
    let prefix = ident(&enter.model);
    let sided_name = format!("{prefix}_sided_albedo{suffix}");
    let split_name = format!("{prefix}_kulla_conty_split{suffix}");
    let share_name = format!("{prefix}_kulla_conty_transmission{suffix}");
    let averages = [
        "f_avg".to_string(),
        "e_avg".to_string(),
        "e_avg_inv".to_string(),
    ];
    let split = Function {
        name: split_name.clone(),
        doc: vec![
            "Kulla & Conty's reciprocity factor x of a rough dielectric interface (Kulla & Conty 2017, \"Revisiting".into(),
            "Physically Based Shading at Imageworks\"): x = η²(1 − F_avg(1/η))(1 − E_avg,1/η) / ((1 − F_avg(η))(1 − E_avg,η) +".into(),
            "η²(1 − F_avg(1/η))(1 − E_avg,1/η)), which the smooth interface's balance η²(1 − F_avg(1/η)) = 1 − F_avg(η)".into(),
            "reduces to (1 − E_avg,1/η) / ((1 − E_avg,η) + (1 − E_avg,1/η)). e_avg = E_avg,η and e_avg_inv = E_avg,1/η".into(),
            format!("are 2 ∫ E(μ) μ dμ of {} and {} at the same f0 and r (the `-avg` models).", enter.function, albedos.iter().find(|a| a.id == Some(leaving)).map_or(String::new(), |a| a.function.clone())),
            format!("Returns 1/2 where both 1 − E_avg are below {KULLA_CONTY_FLOOR:e} (no lobe is on there)."),
        ],
        params: vec!["e_avg".into(), "e_avg_inv".into()],
        body: vec![Stmt {
            name: "lost".into(),
            value: add(sub(lit(1.0), var("e_avg")), sub(lit(1.0), var("e_avg_inv"))),
            comment: Some("(1 − E_avg,η) + (1 − E_avg,1/η)".into()),
        }],
        result: select_ge(
            var("lost"),
            lit(KULLA_CONTY_FLOOR),
            div(sub(lit(1.0), var("e_avg_inv")), var("lost")), // Kulla & Conty 2017, x
            lit(0.5),
        ),
    };
    let mut share_params = averages.to_vec();
    share_params.extend(["f0".to_string(), "cos_o".to_string()]);
    let share = Function {
        name: share_name.clone(),
        doc: vec![
            "Share t of the energy single scattering loses that Kulla & Conty's lobes transmit, for cos_o = n·ωo".into(),
            "(Kulla & Conty 2017): t = (1 − F_avg(η)) x from outside (cos_o ≥ 0), t = (1 − F_avg(1/η))(1 − x) =".into(),
            "(1 − F_avg(η))(1 − x)/η² from inside, η = (1 + √f0)/(1 − √f0); 1 − t is reflected. f_avg = F_avg(η) = 2 ∫ F μ dμ".into(),
            format!("of the interface's Fresnel from outside (the `fresnel-dielectric` model at f0); x from {split_name}."),
            "With this split the transmitted energy balances both ways, t_out (1 − E_avg,η) = η² t_in (1 − E_avg,1/η).".into(),
        ],
        params: share_params,
        body: vec![
            Stmt {
                name: "x".into(),
                value: call(&split_name, vec![var("e_avg"), var("e_avg_inv")]),
                comment: None,
            },
            Stmt {
                name: "s".into(),
                value: sqrt(max(var("f0"), lit(0.0))),
                comment: Some("√F0; the clamp keeps the square root real".into()),
            },
            Stmt {
                name: "q".into(),
                value: div(sub(lit(1.0), var("s")), add(lit(1.0), var("s"))),
                comment: Some("1/η = (1 − √F0)/(1 + √F0)".into()),
            },
        ],
        result: select_ge(
            var("cos_o"),
            lit(0.0),
            mul(sub(lit(1.0), var("f_avg")), var("x")), // Kulla & Conty 2017, from outside
            mul(
                mul(sub(lit(1.0), var("f_avg")), sub(lit(1.0), var("x"))),
                mul(var("q"), var("q")),
            ), // (1 − F_avg(1/η))(1 − x), 1 − F_avg(1/η) = (1 − F_avg(η))/η²
        ),
    };
    let at = |cos: &str| {
        call(
            &sided_name,
            enter
                .params
                .iter()
                .map(|p| if p == "mu" { var(cos) } else { var(p) })
                .collect(),
        )
    };
    let mut params = averages.to_vec();
    params.extend(enter.params.iter().map(|p| {
        if p == "mu" {
            "cos_o".to_string()
        } else {
            p.clone()
        }
    }));
    params.push("cos_i".into());
    let mut share_args: Vec<super::ir::Expr> = averages.iter().map(|p| var(p)).collect();
    share_args.extend([var("f0"), var("cos_o")]);
    let bsdf = Function {
        name: format!("{prefix}_kulla_conty_bsdf{suffix}"),
        doc: vec![
            "Kulla & Conty's multiple-scattering lobe of a rough dielectric interface (Kulla & Conty 2017; Kelemen &".into(),
            "Szirmay-Kalos 2001), cos_o = n·ωo and cos_i = n·ωi signed, the normal pointing outside: in reflection".into(),
            "(1 − t)(1 − E_s(μo))(1 − E_s(μi)) / (π(1 − E_avg,s)), in transmission t (1 − E_s(μo))(1 − E_s'(μi)) / (π(1 − E_avg,s')),".into(),
            format!("s the side of ωo, s' the other one, E by side from {sided_name}, t from {share_name}."),
            "Add it to the single-scattering BSDF ρ_R + ρ_T: from either side it restores 1 − E(μo), so a white interface".into(),
            "keeps all its energy, and its transmission is reciprocal. Energy form, as the tables: for radiance transport".into(),
            "multiply a transmission value by 1/η² when ωo is outside and by η² when it is inside (furnace's radiance form).".into(),
            format!("Returns 0 where the 1 − E_avg of ωi's side is below {KULLA_CONTY_FLOOR:e}; arguments as for {share_name}."),
        ],
        params,
        body: vec![
            Stmt { name: "e_o".into(), value: at("cos_o"), comment: None },
            Stmt { name: "e_i".into(), value: at("cos_i"), comment: None },
            Stmt {
                name: "t".into(),
                value: call(&share_name, share_args),
                comment: None,
            },
            Stmt {
                name: "share".into(),
                value: select_ge(
                    var("cos_o"),
                    lit(0.0),
                    select_ge(var("cos_i"), lit(0.0), sub(lit(1.0), var("t")), var("t")),
                    select_ge(var("cos_i"), lit(0.0), var("t"), sub(lit(1.0), var("t"))),
                ),
                comment: Some("1 − t when ωi is on ωo's side (reflection), t across (transmission)".into()),
            },
            Stmt {
                name: "one_minus_e_avg".into(),
                value: select_ge(
                    var("cos_i"),
                    lit(0.0),
                    sub(lit(1.0), var("e_avg")),
                    sub(lit(1.0), var("e_avg_inv")),
                ),
                comment: Some(format!("1 − E_avg of ωi's side; guard: below {KULLA_CONTY_FLOOR:e} the lobe is off")),
            },
        ],
        result: select_ge(
            var("one_minus_e_avg"),
            lit(KULLA_CONTY_FLOOR),
            div(
                mul(var("share"), mul(sub(lit(1.0), var("e_o")), sub(lit(1.0), var("e_i")))),
                mul(lit(std::f64::consts::PI), var("one_minus_e_avg")),
            ), // Kulla & Conty 2017, f_R and f_T
            lit(0.0),
        ),
    };
    vec![split, share, bsdf]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emit::ir::{Arith, Compiled, Program};
    use std::f64::consts::{FRAC_PI_2, PI};

    /// A stand-in albedo over (r, aniso, mu, phi) that returns `pick` of its arguments, and the
    /// tangent-frame helpers calling it.
    fn program(pick: &str) -> Program {
        let params: Vec<String> = ["r", "aniso", "mu", "phi"].map(String::from).to_vec();
        let albedo = Function {
            name: "f".into(),
            doc: vec![],
            params: params.clone(),
            body: vec![],
            result: var(pick),
        };
        let a = AlbedoRef {
            model: "ggx-conductor-aniso".into(),
            id: None,
            function: "f".into(),
            params,
        };
        let mut functions = vec![albedo];
        functions.extend(tangent_frame(&a, "p", ""));
        Program { functions }
    }

    #[test]
    fn the_tangent_frame_helpers_form_mu_and_the_reduced_azimuth() {
        let phi = program("phi");
        let mu = program("mu");
        let names: Vec<&str> = phi.functions.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "f",
                "p_direction_albedo",
                "p_turquin_scale",
                "p_turquin_scale_rgb"
            ]
        );
        assert_eq!(names[1..], super::names("p", Helper::TangentFrameTurquin));
        let at_phi = Compiled::new(&phi, "p_direction_albedo").unwrap();
        let at_mu = Compiled::new(&mu, "p_direction_albedo").unwrap();
        let mut regs = Vec::new();
        let mut worst = 0.0f64;
        // every quadrant, both orientations of the tangent, the axes and the diagonals
        for k in 0..=720 {
            let az = -2.0 * PI + 4.0 * PI * k as f64 / 720.0;
            for theta in [0.05f64, 0.7, 1.3, FRAC_PI_2] {
                let wo = [theta.sin() * az.cos(), theta.sin() * az.sin(), theta.cos()];
                let x = [0.5f32, 0.3, wo[0] as f32, wo[1] as f32, wo[2] as f32];
                // the azimuth reduced by E(φ) = E(−φ) = E(π − φ)
                let p = az.rem_euclid(PI);
                let want = p.min(PI - p);
                let got = at_phi.eval_f32(&x, Arith::Ieee, &mut regs) as f64;
                worst = worst.max((got - want).abs());
                assert!((0.0..=FRAC_PI_2 as f32 as f64).contains(&got), "{got}");
                assert_eq!(at_mu.eval_f32(&x, Arith::Ieee, &mut regs), wo[2] as f32);
            }
        }
        // A&S 4.4.49's 2e-8 and f32 rounding of the inputs and the operations
        assert!(worst < 1e-6, "max |φ − reduced azimuth| {worst:e}");
        // normal incidence: φ = 0, no NaN
        let x = [0.5f32, 0.3, 0.0, -0.0, 1.0];
        assert_eq!(at_phi.eval_f32(&x, Arith::Ieee, &mut regs), 0.0);
        // Turquin's scale and its RGB form from the same E (Sforza & Pellacini 2022, eq. 13)
        let e = 0.25f32; // mu of the stand-in
        let wo = [0.6f32, -0.7, e];
        let scalar = Compiled::new(&mu, "p_turquin_scale").unwrap();
        let rgb = Compiled::new(&mu, "p_turquin_scale_rgb").unwrap();
        for f0 in [0.0f32, 0.5, 1.0] {
            let got = scalar.eval_f32(&[f0, 0.5, 0.3, wo[0], wo[1], wo[2]], Arith::Ieee, &mut regs);
            assert_eq!(got, 1.0 + f0 * ((1.0 - e) / e));
        }
        rgb.eval_f32(
            &[0.0, 0.5, 1.0, 0.5, 0.3, wo[0], wo[1], wo[2]],
            Arith::Ieee,
            &mut regs,
        );
        let out: Vec<f32> = rgb.results().iter().map(|&r| regs[r]).collect();
        assert_eq!(out, [1.0, 1.0 + 0.5 * ((1.0 - e) / e), 1.0 + (1.0 - e) / e]);
    }

    #[test]
    fn abramowitz_and_stegun_4_4_49_is_within_its_bound() {
        let mut worst = 0.0f64;
        for k in 0..=100_000 {
            let t = k as f64 / 100_000.0;
            let p = ATAN_COEFFICIENTS
                .iter()
                .rev()
                .fold(0.0, |acc, &c| acc * t * t + c);
            worst = worst.max((t * p - t.atan()).abs());
        }
        assert!(worst <= 2e-8, "{worst:e}");
    }

    #[test]
    fn an_albedo_without_an_azimuth_gets_no_tangent_frame_helpers() {
        let a = AlbedoRef {
            model: "ggx-conductor".into(),
            id: None,
            function: "f".into(),
            params: vec!["r".into(), "mu".into()],
        };
        assert!(tangent_frame(&a, "p", "").is_empty());
    }
}
