//! The one list of material classes: the built-in ones, then any a program [`register`]s.

use super::anisotropic::AnisotropicConductor;
use super::builtin::Kind;
use super::{CompensatedBsdf, Helper, MaterialClass};
use crate::bsdf::ModelId;
use crate::error::{Error, Result};
use crate::math::SmithForm;
use std::sync::{Arc, OnceLock, RwLock, RwLockReadGuard};

fn registry() -> &'static RwLock<Vec<Arc<dyn MaterialClass>>> {
    static REGISTRY: OnceLock<RwLock<Vec<Arc<dyn MaterialClass>>>> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut list: Vec<Arc<dyn MaterialClass>> = Kind::ALL
            .iter()
            .map(|&k| Arc::new(k) as Arc<dyn MaterialClass>)
            .collect();
        list.push(Arc::new(AnisotropicConductor));
        RwLock::new(list)
    })
}

fn read() -> RwLockReadGuard<'static, Vec<Arc<dyn MaterialClass>>> {
    // a panic while registering leaves the list as it was before the push: still consistent
    registry().read().unwrap_or_else(|e| e.into_inner())
}

/// Adds a material class after the built-in ones. From then on scene manifests accept its kind,
/// the report runs the white furnace test of its compensated BSDFs in the sections of their
/// albedo models, and the emitters write its helpers next to those albedos. Refused if the kind
/// is taken or not lower-case letters, digits and `-`, or if a table it reads is not a
/// registered model (register the model first).
pub fn register(class: impl MaterialClass + 'static) -> Result<()> {
    let kind = class.kind();
    if kind.is_empty()
        || !kind
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
    {
        return Err(Error::InvalidInput(format!(
            "material kind '{kind}' must be non-empty lower-case letters, digits or '-' (scene manifests spell it)"
        )));
    }
    for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
        if class.tables(smith).is_empty() {
            return Err(Error::InvalidInput(format!(
                "material kind '{kind}' reads no albedo table; it needs at least one"
            )));
        }
        for t in class.tables(smith) {
            crate::bsdf::get(t.model).map_err(|e| {
                Error::InvalidInput(format!(
                    "material kind '{kind}' reads {}: {e}; register the model first",
                    t.model
                ))
            })?;
        }
    }
    let mut list = registry().write().unwrap_or_else(|e| e.into_inner());
    if list.iter().any(|c| c.kind() == kind) {
        return Err(Error::InvalidInput(format!(
            "a material kind '{kind}' is already registered; give the new one another kind"
        )));
    }
    list.push(Arc::new(class));
    Ok(())
}

/// Every registered class, built-in ones first.
pub fn classes() -> Vec<Arc<dyn MaterialClass>> {
    read().clone()
}

/// The known kinds, comma separated (for error messages).
pub fn known_kinds() -> String {
    read()
        .iter()
        .map(|c| c.kind())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The class of kind `kind`.
pub fn find(kind: &str) -> Result<Arc<dyn MaterialClass>> {
    read()
        .iter()
        .find(|c| c.kind() == kind)
        .cloned()
        .ok_or_else(|| {
            Error::InvalidInput(format!(
                "unknown kind '{kind}'; known kinds: {}",
                known_kinds()
            ))
        })
}

/// The compensated BSDFs of every class whose primary albedo is `model` (in `model`'s Smith
/// form and transmission convention), in registry order: what the furnace test of `model`'s
/// report section checks.
pub fn compensated_for(model: ModelId) -> Vec<Arc<dyn CompensatedBsdf>> {
    let smith = model.smith.unwrap_or_default();
    let transmission = model.transmission.unwrap_or_default();
    read()
        .iter()
        .flat_map(|c| c.compensated(smith, transmission))
        .filter(|m| m.albedos().first() == Some(&model))
        .collect()
}

/// The helpers any class emits next to an albedo function of `model`, in [`Helper`]'s order,
/// each with the purposes of the classes that use it (registry order): what `furnace emit`
/// writes for a fit of it.
pub fn helpers_for(model: ModelId) -> Vec<(Helper, Vec<Vec<String>>)> {
    let mut out: Vec<(Helper, Vec<Vec<String>>)> = Vec::new();
    for c in read().iter() {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            for t in c.tables(smith).into_iter().filter(|t| t.model == model) {
                for u in t.helpers {
                    match out.iter_mut().find(|(h, _)| *h == u.helper) {
                        Some((_, purposes)) => {
                            if !purposes.contains(&u.purpose) {
                                purposes.push(u.purpose);
                            }
                        }
                        None => out.push((u.helper, vec![u.purpose])),
                    }
                }
            }
        }
    }
    out.sort_by_key(|(h, _)| *h);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Side;

    #[test]
    fn the_builtin_classes_name_their_tables_helpers_and_furnace_materials() {
        assert_eq!(
            known_kinds(),
            "conductor, thin-dielectric, glossy, dielectric, rough-diffuse, anisotropic-conductor"
        );
        let sep = SmithForm::Separable;
        let kinds =
            |m: ModelId| -> Vec<Helper> { helpers_for(m).into_iter().map(|h| h.0).collect() };
        assert_eq!(
            kinds(ModelId::ggx_conductor(sep)),
            [
                Helper::TurquinScale,
                Helper::KullaConty,
                Helper::Normalization
            ]
        );
        // the conductor's 1/E serves the thin dielectric and the glossy layer, in registry order
        let normalization = &helpers_for(ModelId::ggx_conductor(sep))[2].1;
        assert!(normalization.len() == 2 && normalization[1][0].contains("glossy"));
        let enter = ModelId::ggx_dielectric(Side::Entering, sep);
        let leave = ModelId::ggx_dielectric(Side::Leaving, sep);
        assert_eq!(
            kinds(enter),
            [
                Helper::Normalization,
                Helper::Sided { leaving: leave },
                Helper::KullaContyDielectric { leaving: leave }
            ]
        );
        assert_eq!(kinds(leave), [Helper::Normalization]);
        let ids =
            |m: ModelId| -> Vec<String> { compensated_for(m).iter().map(|c| c.id()).collect() };
        assert_eq!(
            ids(ModelId::ggx_conductor(sep)),
            [
                "conductor-separable",
                "conductor-kulla-conty-separable",
                "conductor-kulla-conty-f0-0.5-separable",
                "thin-dielectric-separable"
            ]
        );
        assert_eq!(
            ids(leave),
            [
                "dielectric-inv-separable",
                "dielectric-inv-kulla-conty-separable"
            ]
        );
        // Kulla–Conty's lobes only in the energy form: no white furnace in the radiance form
        assert_eq!(
            ids(leave.with_transmission(crate::bsdf::Transmission::Radiance)),
            ["dielectric-inv-separable-radiance"]
        );
        assert_eq!(
            ids(crate::bsdf::lookup("oren-nayar-fon").unwrap()),
            ["rough-diffuse"]
        );
        assert!(ids(crate::bsdf::lookup("eon").unwrap()).is_empty());
        let aniso = crate::bsdf::lookup("ggx-conductor-aniso-separable").unwrap();
        assert_eq!(kinds(aniso), [Helper::TangentFrameTurquin]);
        assert_eq!(ids(aniso), ["anisotropic-conductor-separable"]);
        let e = find("velvet").map(|_| ()).unwrap_err().to_string();
        assert!(
            e.contains("unknown kind 'velvet'; known kinds: conductor"),
            "{e}"
        );
        assert!(register(Kind::Conductor)
            .unwrap_err()
            .to_string()
            .contains("already registered"));
    }
}
