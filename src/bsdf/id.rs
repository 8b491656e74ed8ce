//! A model's identity as a value: family, Smith form, side of the interface and transmission
//! convention. Its text form is the model's name (`ggx-dielectric-inv-separable`), built here
//! and nowhere else; text is turned back into an identity only through the registry
//! ([`super::lookup`]), so a name is never taken apart by its suffixes.
//!
//! | field | values | in the name |
//! | --- | --- | --- |
//! | [`Family`] | `ggx-conductor`, `ggx-dielectric`, `ggx-glossy`, `oren-nayar-fon`, … or a user's | the stem |
//! | [`Side`] (dielectrics) | entering (relative IOR η), leaving (1/η) | `-inv` when leaving |
//! | [`SmithForm`] (microfacet families) | height-correlated, separable | `-separable` when separable |
//! | [`Transmission`] (dielectrics) | energy, radiance | `-radiance` in the [key](ModelId::key) only |
//! | `average` (models with a `mu` axis) | E, or its cosine-weighted average E_avg over μ | `-avg` when averaged |

use crate::math::SmithForm;
use std::fmt;

/// A family of models: the stem of their names. The built-in families are the constants below;
/// a user's model names its own with [`Family::new`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Family(&'static str);

impl Family {
    /// White GGX conductor (F = 1).
    pub const GGX_CONDUCTOR: Family = Family("ggx-conductor");
    /// Anisotropic white GGX conductor, OpenPBR's (r, aniso) roughness.
    pub const GGX_CONDUCTOR_ANISO: Family = Family("ggx-conductor-aniso");
    /// GGX rough dielectric interface (reflection + transmission).
    pub const GGX_DIELECTRIC: Family = Family("ggx-dielectric");
    /// GGX specular layer over a diffuse base: E_spec / E_ss (paper eq. 17).
    pub const GGX_GLOSSY: Family = Family("ggx-glossy");
    /// Qualitative Oren–Nayar.
    pub const OREN_NAYAR_QON: Family = Family("oren-nayar-qon");
    /// Fujii's Oren–Nayar.
    pub const OREN_NAYAR_FON: Family = Family("oren-nayar-fon");
    /// Energy-preserving Oren–Nayar.
    pub const EON: Family = Family("eon");
    /// Radziszewski & Alda's energy-conserving glossy lobe.
    pub const RADZISZEWSKI_GLOSSY: Family = Family("radziszewski-glossy");
    /// The split-sum terms A, B of a GGX reflection with Schlick's Fresnel.
    pub const GGX_SPLIT_SUM: Family = Family("ggx-split-sum");
    /// Visible-normal average of the generalised-Schlick factor (1 − ωo·h)^p (Cycles).
    pub const GGX_GEN_SCHLICK: Family = Family("ggx-gen-schlick");
    /// Visible-normal average of the remapped dielectric Fresnel (Cycles).
    pub const GGX_GEN_SCHLICK_IOR: Family = Family("ggx-gen-schlick-ior");
    /// F_avg of Schlick's Fresnel.
    pub const FRESNEL_SCHLICK: Family = Family("fresnel-schlick");
    /// F_avg of the exact dielectric Fresnel (a side of the interface).
    pub const FRESNEL_DIELECTRIC: Family = Family("fresnel-dielectric");
    /// F_avg of the F82-tint conductor Fresnel (OpenPBR, Adobe Standard Material).
    pub const FRESNEL_F82_TINT: Family = Family("fresnel-f82-tint");

    /// A family named `name` (lower-case letters, digits and `-`; checked when a model of it is
    /// registered, since the name becomes a folder under `data/` and `fits/`).
    pub const fn new(name: &'static str) -> Family {
        Family(name)
    }

    pub const fn name(self) -> &'static str {
        self.0
    }
}

/// Which side of a dielectric interface ωo is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Side {
    /// Outside, travelling into the denser medium: relative IOR η = (1+√F0)/(1−√F0).
    Entering,
    /// Inside, leaving it: relative IOR 1/η, with total internal reflection (name suffix `-inv`).
    Leaving,
}

/// Convention of tabulated transmission.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Transmission {
    /// E_T without the 1/η² radiance factor: E_R + E_T → 1 as α → 0 (furnace's convention).
    #[default]
    Energy,
    /// E_T in radiance form (×1/η² entering, ×η² leaving), as the paper's repository tabulates.
    Radiance,
}

/// A model's identity. Fields that do not apply to a family are `None` (a conductor has no
/// side and no transmission; a rough-diffuse model has no Smith form).
///
/// ```
/// use furnace::bsdf::{ModelId, Side, Transmission};
/// use furnace::math::SmithForm;
/// let id = ModelId::ggx_dielectric(Side::Leaving, SmithForm::Separable);
/// assert_eq!(id.name(), "ggx-dielectric-inv-separable");
/// let paper = id.with_transmission(Transmission::Radiance);
/// assert_eq!(paper.key(), "ggx-dielectric-inv-separable-radiance");
/// assert_eq!(paper.name(), id.name()); // the transmission is a table parameter, not in the name
/// assert_eq!("ggx-dielectric-inv-separable-radiance".parse::<ModelId>().unwrap(), paper);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModelId {
    pub family: Family,
    pub smith: Option<SmithForm>,
    pub side: Option<Side>,
    pub transmission: Option<Transmission>,
    /// The cosine-weighted average over μ of the model's outputs, E_avg = 2∫₀¹ E(μ) μ dμ
    /// (Kulla & Conty 2017), instead of the outputs themselves ([`super::average`]).
    pub average: bool,
}

impl ModelId {
    /// A model of `family` with no Smith form, side or transmission.
    pub const fn new(family: Family) -> ModelId {
        ModelId {
            family,
            smith: None,
            side: None,
            transmission: None,
            average: false,
        }
    }

    pub const fn with_smith(self, smith: SmithForm) -> ModelId {
        ModelId {
            smith: Some(smith),
            ..self
        }
    }

    pub const fn with_side(self, side: Side) -> ModelId {
        ModelId {
            side: Some(side),
            ..self
        }
    }

    pub const fn with_transmission(self, transmission: Transmission) -> ModelId {
        ModelId {
            transmission: Some(transmission),
            ..self
        }
    }

    /// The cosine-weighted average over μ of this model ([`ModelId::average`]).
    pub const fn averaged(self) -> ModelId {
        ModelId {
            average: true,
            ..self
        }
    }

    /// The model this one averages over μ (itself when it is not an average).
    pub const fn unaveraged(self) -> ModelId {
        ModelId {
            average: false,
            ..self
        }
    }

    /// The GGX white conductor with Smith form `smith`.
    pub const fn ggx_conductor(smith: SmithForm) -> ModelId {
        ModelId::new(Family::GGX_CONDUCTOR).with_smith(smith)
    }

    /// The GGX glossy ratio with Smith form `smith`.
    pub const fn ggx_glossy(smith: SmithForm) -> ModelId {
        ModelId::new(Family::GGX_GLOSSY).with_smith(smith)
    }

    /// The GGX dielectric seen from `side`, energy-form transmission.
    pub const fn ggx_dielectric(side: Side, smith: SmithForm) -> ModelId {
        ModelId::new(Family::GGX_DIELECTRIC)
            .with_side(side)
            .with_smith(smith)
            .with_transmission(Transmission::Energy)
    }

    /// The model's name: what `--model` takes, and what table sidecars and fit files record
    /// (with the transmission convention beside it, in the table's parameters).
    pub fn name(&self) -> String {
        let mut s = self.family.name().to_string();
        if self.side == Some(Side::Leaving) {
            s.push_str("-inv");
        }
        if self.smith == Some(SmithForm::Separable) {
            s.push_str("-separable");
        }
        if self.average {
            s.push_str("-avg");
        }
        s
    }

    /// The name with `-radiance` for radiance-form transmission: unique among the registered
    /// models, the folder of the model's tables under `data/`, fits under `fits/` and report
    /// section under `reports/`.
    pub fn key(&self) -> String {
        let mut s = self.name();
        if self.transmission == Some(Transmission::Radiance) {
            s.push_str("-radiance");
        }
        s
    }

    /// Whether transmission is tabulated in radiance form (the paper's convention).
    pub fn is_radiance(&self) -> bool {
        self.transmission == Some(Transmission::Radiance)
    }

    /// The same model in furnace's energy form (itself when it has no transmission).
    pub fn energy_form(self) -> ModelId {
        match self.transmission {
            Some(_) => self.with_transmission(Transmission::Energy),
            None => self,
        }
    }
}

impl fmt::Display for ModelId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(&self.key())
    }
}

impl std::str::FromStr for ModelId {
    type Err = crate::Error;
    /// The registered model whose [key](ModelId::key) is `s`.
    fn from_str(s: &str) -> crate::Result<ModelId> {
        super::lookup(s)
    }
}

impl serde::Serialize for ModelId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(&self.key())
    }
}

impl<'de> serde::Deserialize<'de> for ModelId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<ModelId, D::Error> {
        let key = String::deserialize(d)?;
        key.parse().map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_of_every_builtin_variant() {
        use SmithForm::*;
        let cases = [
            (ModelId::ggx_conductor(HeightCorrelated), "ggx-conductor"),
            (ModelId::ggx_conductor(Separable), "ggx-conductor-separable"),
            (ModelId::ggx_glossy(Separable), "ggx-glossy-separable"),
            (
                ModelId::ggx_dielectric(Side::Entering, HeightCorrelated),
                "ggx-dielectric",
            ),
            (
                ModelId::ggx_dielectric(Side::Leaving, HeightCorrelated),
                "ggx-dielectric-inv",
            ),
            (
                ModelId::ggx_dielectric(Side::Leaving, Separable),
                "ggx-dielectric-inv-separable",
            ),
            (ModelId::new(Family::EON), "eon"),
        ];
        for (id, name) in cases {
            assert_eq!(id.name(), name);
            assert_eq!(id.key(), name);
            assert_eq!(id.to_string(), name);
            assert_eq!(name.parse::<ModelId>().unwrap(), id, "{name}");
        }
        let r = ModelId::ggx_dielectric(Side::Entering, Separable)
            .with_transmission(Transmission::Radiance);
        assert_eq!(r.name(), "ggx-dielectric-separable");
        assert_eq!(r.key(), "ggx-dielectric-separable-radiance");
        assert!(r.is_radiance() && !r.energy_form().is_radiance());
        assert_eq!(
            serde_json::to_string(&r).unwrap(),
            "\"ggx-dielectric-separable-radiance\""
        );
        assert_eq!(
            serde_json::from_str::<ModelId>("\"ggx-dielectric-separable-radiance\"").unwrap(),
            r
        );
        assert!(serde_json::from_str::<ModelId>("\"ggx-conductor-radiance\"").is_err());
        let avg = ModelId::ggx_dielectric(Side::Leaving, Separable).averaged();
        assert_eq!(avg.name(), "ggx-dielectric-inv-separable-avg");
        assert_eq!(
            avg.with_transmission(Transmission::Radiance).key(),
            "ggx-dielectric-inv-separable-avg-radiance"
        );
        assert_eq!(
            "ggx-dielectric-inv-separable-avg"
                .parse::<ModelId>()
                .unwrap(),
            avg
        );
        assert_eq!(avg.unaveraged().name(), "ggx-dielectric-inv-separable");
        assert_eq!(
            "eon-avg".parse::<ModelId>().unwrap(),
            ModelId::new(Family::EON).averaged()
        );
    }
}
