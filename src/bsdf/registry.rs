//! The one list of models: the built-in ones, then any a program [`register`]s. Everything that
//! turns a name into a model (the CLI, scenes, reports, emitters, fit files) asks it.
//!
//! It also holds the default set ([`default_set`]): the models `furnace run` tabulates, fits,
//! emits and reports, and `furnace report` covers, when none are named. A program adds a model
//! of its own to it with [`register_in_default_set`].

use super::average::AverageAlbedo;
use super::{
    diffuse, fresnel, ggx, ggx_aniso, radziszewski, weighted, Family, Model, ModelId, Side,
    Transmission, MAX_OUTPUTS,
};
use crate::error::{Error, Result};
use crate::math::SmithForm;
use std::sync::{Arc, OnceLock, RwLock, RwLockReadGuard};

/// The built-in models in the order `furnace models` lists them, then the transmission
/// variants (which `--transmission` selects rather than a name).
fn builtins() -> Vec<Arc<dyn Model>> {
    let mut models: Vec<Arc<dyn Model>> = Vec::new();
    for m in ggx::all() {
        models.push(Arc::new(m));
    }
    for m in ggx_aniso::AnisoConductor::all() {
        models.push(Arc::new(m));
    }
    for kind in [
        diffuse::DiffuseKind::Qon,
        diffuse::DiffuseKind::Fon,
        diffuse::DiffuseKind::Eon,
    ] {
        models.push(Arc::new(diffuse::DiffuseModel::new(kind)));
    }
    models.push(Arc::new(radziszewski::RadziszewskiModel));
    for m in weighted::all() {
        models.push(Arc::new(m));
    }
    for m in fresnel::all() {
        models.push(Arc::new(m));
    }
    for m in ggx::radiance_variants() {
        models.push(Arc::new(m));
    }
    let averages: Vec<Arc<dyn Model>> = models
        .iter()
        .filter_map(|m| AverageAlbedo::new(m.clone()))
        .map(|a| Arc::new(a) as Arc<dyn Model>)
        .collect();
    models.extend(averages);
    models
}

/// The built-in models of the default set, in its order: the paper's GGX tables (conductor,
/// glossy, dielectric entering and leaving) in both Smith forms, then the rough-diffuse models.
fn builtin_default_set() -> Vec<ModelId> {
    let ggx: [fn(SmithForm) -> ModelId; 4] = [
        ModelId::ggx_conductor,
        ModelId::ggx_glossy,
        |smith| ModelId::ggx_dielectric(Side::Entering, smith),
        |smith| ModelId::ggx_dielectric(Side::Leaving, smith),
    ];
    let mut ids = Vec::new();
    for table in ggx {
        for smith in [SmithForm::HeightCorrelated, SmithForm::Separable] {
            ids.push(table(smith));
        }
    }
    for family in [Family::OREN_NAYAR_QON, Family::OREN_NAYAR_FON, Family::EON] {
        ids.push(ModelId::new(family));
    }
    ids
}

/// The registered models, and the identities of those in the default set, in its order.
struct Registry {
    models: Vec<Arc<dyn Model>>,
    default_set: Vec<ModelId>,
}

fn registry() -> &'static RwLock<Registry> {
    static REGISTRY: OnceLock<RwLock<Registry>> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        RwLock::new(Registry {
            models: builtins(),
            default_set: builtin_default_set(),
        })
    })
}

fn read() -> RwLockReadGuard<'static, Registry> {
    // a panic while registering leaves the lists as they were before the push: still consistent
    registry().read().unwrap_or_else(|e| e.into_inner())
}

/// Checks what the rest of furnace relies on: a key that can name a folder, axes with sane
/// ranges, and between one and [`MAX_OUTPUTS`] distinct outputs whose names can name a
/// channel and a function (the first is the one a fit takes by default).
fn check(model: &dyn Model) -> std::result::Result<(), String> {
    let key = model.id().key();
    if key.is_empty()
        || !key
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_')
    {
        return Err(format!(
            "model name '{key}' must be non-empty lower-case letters, digits, '-' or '_' (it names folders under data/ and fits/)"
        ));
    }
    let axes = model.axes();
    if axes.is_empty() {
        return Err(format!("model {key} has no axes"));
    }
    for (k, a) in axes.iter().enumerate() {
        if axes[..k].iter().any(|b| b.name == a.name) {
            return Err(format!("model {key} has two axes named {}", a.name));
        }
        let ((lo, hi), (vlo, vhi)) = (a.default_range, a.valid_range);
        if !(lo < hi && vlo <= lo && hi <= vhi) {
            return Err(format!(
                "model {key}: axis {} has default range [{lo}, {hi}], which must be non-empty and inside its valid range [{vlo}, {vhi}]",
                a.name
            ));
        }
    }
    let outputs = model.outputs();
    let well_named = |o: &str| {
        o.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
            && o.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    if outputs.is_empty()
        || outputs.len() > MAX_OUTPUTS
        || !outputs.iter().all(|o| well_named(o))
        || outputs
            .iter()
            .enumerate()
            .any(|(k, o)| outputs[..k].contains(o))
    {
        return Err(format!(
            "model {key}: outputs {outputs:?} must be 1 to {MAX_OUTPUTS} distinct names of letters, digits and '_' starting with a letter"
        ));
    }
    Ok(())
}

/// Adds `model` to the registry, after the built-in models, and returns its identity. From
/// then on every part of furnace finds it by name: tabulation, fits, emitters, reports and
/// scenes. A model with a `mu` axis over [0, 1] brings its average over μ with it
/// (`<name>-avg`, [`AverageAlbedo`]). Refused if its name (or its average's) is taken or its
/// axes or outputs are malformed.
pub fn register(model: impl Model + 'static) -> Result<ModelId> {
    add(model, false)
}

/// [`register`], and adds the model to the default set after the models already in it: from
/// then on `furnace run`'s job ([`crate::pipeline::Job::default_set`]) tabulates, fits, emits and
/// reports it, and the report ([`crate::report::model::Reporter::generate`]) covers it, with no
/// other change. Its average over μ is registered but not added.
pub fn register_in_default_set(model: impl Model + 'static) -> Result<ModelId> {
    add(model, true)
}

fn add(model: impl Model + 'static, in_default_set: bool) -> Result<ModelId> {
    check(&model).map_err(Error::InvalidInput)?;
    let id = model.id();
    let model: Arc<dyn Model> = Arc::new(model);
    let average = AverageAlbedo::new(model.clone()).map(|a| Arc::new(a) as Arc<dyn Model>);
    let mut registry = registry().write().unwrap_or_else(|e| e.into_inner());
    for m in std::iter::once(&model).chain(&average) {
        if registry.models.iter().any(|l| l.id().key() == m.id().key()) {
            return Err(Error::InvalidInput(format!(
                "a model named {} is already registered; give the new one another family name",
                m.id()
            )));
        }
    }
    registry.models.push(model);
    registry.models.extend(average);
    if in_default_set {
        registry.default_set.push(id);
    }
    Ok(id)
}

/// Every registered model, built-in ones first, in registration order.
pub fn models() -> Vec<Arc<dyn Model>> {
    read().models.clone()
}

/// The default set: the built-in models of the paper's tables in both Smith forms and the
/// rough-diffuse models, then every model added with [`register_in_default_set`], in that order.
pub fn default_set() -> Vec<ModelId> {
    read().default_set.clone()
}

/// The models `furnace models` lists: every registered one but the transmission variants.
pub fn listed() -> Vec<Arc<dyn Model>> {
    read()
        .models
        .iter()
        .filter(|m| !m.id().is_radiance())
        .cloned()
        .collect()
}

/// Names of the listed models, comma separated (for error messages).
pub fn known_names() -> String {
    listed()
        .iter()
        .map(|m| m.id().name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The identity of the registered model whose [key](ModelId::key) is `key`.
pub fn lookup(key: &str) -> Result<ModelId> {
    read()
        .models
        .iter()
        .map(|m| m.id())
        .find(|id| id.key() == key)
        .ok_or_else(|| Error::UnknownModel {
            name: key.to_string(),
            known: known_names(),
        })
}

/// The registered model of identity `id`.
pub fn get(id: ModelId) -> Result<Arc<dyn Model>> {
    read()
        .models
        .iter()
        .find(|m| m.id() == id)
        .cloned()
        .ok_or_else(|| Error::UnknownModel {
            name: id.key(),
            known: known_names(),
        })
}

/// The registered model whose key is `key`.
pub fn find(key: &str) -> Result<Arc<dyn Model>> {
    get(lookup(key)?)
}

/// The model called `name` with its transmission in the given convention (`--transmission`):
/// radiance form exists only for models with transmission.
pub fn find_variant(name: &str, transmission: Transmission) -> Result<Arc<dyn Model>> {
    let id = lookup(name)?;
    if transmission == Transmission::Energy || id.transmission == Some(transmission) {
        return get(id);
    }
    let wanted = id.with_transmission(transmission);
    if id.transmission.is_some() {
        if let Ok(m) = get(wanted) {
            return Ok(m);
        }
    }
    let with: Vec<String> = read()
        .models
        .iter()
        .filter(|m| m.id().transmission == Some(transmission))
        .map(|m| m.id().name())
        .collect();
    Err(Error::InvalidInput(format!(
        "--transmission {} applies only to the models with transmission ({}), not '{name}'",
        serde_json::to_value(transmission)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default(),
        with.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{AxisSpec, Family};
    use crate::quadrature::Rules;

    struct Flat(&'static str, Vec<&'static str>);

    impl Model for Flat {
        fn id(&self) -> ModelId {
            ModelId::new(Family::new(self.0))
        }
        fn summary(&self) -> String {
            "E = 1".into()
        }
        fn axes(&self) -> Vec<AxisSpec> {
            vec![
                AxisSpec::new("r", (0.0, 1.0), (0.0, 1.0), "roughness"),
                AxisSpec::new("mu", (0.0, 1.0), (0.0, 1.0), "cosine"),
            ]
        }
        fn outputs(&self) -> Vec<&'static str> {
            self.1.clone()
        }
        fn integrate(&self, _: &[f64], _: &Rules) -> [f64; MAX_OUTPUTS] {
            [1.0, 0.0, 0.0]
        }
    }

    #[test]
    fn a_registered_model_is_found_by_name_and_names_are_unique() {
        let id = register(Flat("registry-test-flat", vec!["E"])).unwrap();
        assert_eq!(lookup("registry-test-flat").unwrap(), id);
        assert_eq!(find("registry-test-flat").unwrap().summary(), "E = 1");
        assert!(listed().iter().any(|m| m.id() == id));
        let again = register(Flat("registry-test-flat", vec!["E"]))
            .map(|_| ())
            .unwrap_err();
        assert!(again.to_string().contains("already registered"), "{again}");
        let taken = register(Flat("ggx-conductor", vec!["E"])).unwrap_err();
        assert!(taken.to_string().contains("already registered"), "{taken}");
        let bad = register(Flat("Bad Name", vec!["E"])).unwrap_err();
        assert!(bad.to_string().contains("lower-case letters"), "{bad}");
        let bad_output = register(Flat("registry-test-bad-output", vec!["E", "E"])).unwrap_err();
        assert!(
            bad_output.to_string().contains("distinct names"),
            "{bad_output}"
        );
        let no_output = register(Flat("registry-test-no-output", vec![])).unwrap_err();
        assert!(no_output.to_string().contains("1 to"), "{no_output}");
        // a model with a mu axis brings its average
        let avg = lookup("registry-test-flat-avg").unwrap();
        assert_eq!(avg, id.averaged());
        assert_eq!(get(avg).unwrap().axes().len(), 1);
    }

    #[test]
    fn transmission_variants_are_selected_not_listed() {
        let m = find_variant("ggx-dielectric-inv", Transmission::Radiance).unwrap();
        assert_eq!(m.id().key(), "ggx-dielectric-inv-radiance");
        assert!(listed().iter().all(|m| !m.id().is_radiance()));
        let e = find_variant("ggx-conductor", Transmission::Radiance)
            .map(|_| ())
            .unwrap_err();
        assert!(
            e.to_string().contains("ggx-dielectric-inv-separable")
                && e.to_string().contains("not 'ggx-conductor'"),
            "{e}"
        );
        let e = find("velvet").map(|_| ()).unwrap_err().to_string();
        assert!(
            e.contains("unknown model 'velvet'") && e.contains("eon"),
            "{e}"
        );
    }
}
