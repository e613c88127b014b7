//! Named, switchable physical effects.
//!
//! Every physical effect a model applies is a named unit (`env.fog_extinction`, `space.multipath`,
//! `lidar.range_walk`, ...) that can be switched on and off by name, so the consistency workflow can
//! attribute a model/measurement discrepancy to a missing effect and show the error fall when it is
//! enabled. Each module declares its effects as [`EffectInfo`] constants (name, default, formula and
//! source); an [`Effects`] set holds the switches of one model instance.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Static description of one physical effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EffectInfo {
    /// Dotted name, `<layer>.<effect>`, e.g. `env.fog_extinction`.
    pub name: &'static str,
    /// Whether the effect is on unless configured otherwise.
    pub default_on: bool,
    /// One line: what the effect does, with its formula.
    pub summary: &'static str,
    /// Where the formula or coefficients come from.
    pub source: &'static str,
}

/// Errors of effect configuration.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EffectError {
    #[error("unknown effect `{name}` (known: {known})")]
    Unknown { name: String, known: String },
}

/// The on/off switches of a set of known effects.
#[derive(Debug, Clone, PartialEq)]
pub struct Effects {
    known: BTreeMap<&'static str, EffectInfo>,
    on: BTreeMap<&'static str, bool>,
}

/// Serialized form: effect name → on/off (only the ones that differ from the default need be listed).
pub type EffectSwitches = BTreeMap<String, bool>;

impl Effects {
    /// All `known` effects at their defaults.
    pub fn new(known: &[EffectInfo]) -> Effects {
        let known: BTreeMap<_, _> = known.iter().map(|e| (e.name, *e)).collect();
        let on = known.values().map(|e| (e.name, e.default_on)).collect();
        Effects { known, on }
    }

    /// All `known` effects at their defaults, then `switches` applied; unknown names are errors.
    pub fn with_switches(
        known: &[EffectInfo],
        switches: &EffectSwitches,
    ) -> Result<Effects, EffectError> {
        let mut e = Effects::new(known);
        for (name, &value) in switches {
            e.set(name, value)?;
        }
        Ok(e)
    }

    /// Switch one effect.
    pub fn set(&mut self, name: &str, on: bool) -> Result<(), EffectError> {
        match self.known.get_key_value(name) {
            Some((&key, _)) => {
                self.on.insert(key, on);
                Ok(())
            }
            None => Err(EffectError::Unknown {
                name: name.to_owned(),
                known: self.known.keys().copied().collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// Whether an effect is on. Panics on a name that was never declared: that is a programming
    /// error in the model, not a user input.
    pub fn is_on(&self, info: &EffectInfo) -> bool {
        *self
            .on
            .get(info.name)
            .unwrap_or_else(|| panic!("effect `{}` is not declared", info.name))
    }

    /// Every known effect with its current state, sorted by name.
    pub fn iter(&self) -> impl Iterator<Item = (&EffectInfo, bool)> {
        self.known.values().map(|e| (e, self.on[e.name]))
    }

    /// The switches as a serialisable map (all effects).
    pub fn to_switches(&self) -> EffectSwitches {
        self.on.iter().map(|(k, v)| (k.to_string(), *v)).collect()
    }
}

/// Every physical effect osiris declares, sorted by name: the catalogue `osiris effects` prints and
/// the README lists (a test keeps them in step).
pub fn catalogue() -> Vec<EffectInfo> {
    let mut all: Vec<EffectInfo> = [
        crate::environment::material::EFFECTS,
        crate::environment::weather::EFFECTS,
        crate::space::EFFECTS,
        &crate::lidar::effects(),
        &crate::radar::effects(),
        &crate::camera::effects(),
    ]
    .concat();
    all.sort_by_key(|e| e.name);
    all
}

/// Serde helper so configs can carry `"effects": {"env.fog_extinction": false}`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct EffectConfig(pub EffectSwitches);

#[cfg(test)]
mod tests {
    use super::*;

    const A: EffectInfo = EffectInfo {
        name: "env.a",
        default_on: true,
        summary: "a",
        source: "s",
    };
    const B: EffectInfo = EffectInfo {
        name: "env.b",
        default_on: false,
        summary: "b",
        source: "s",
    };

    #[test]
    fn catalogue_names_are_unique_and_documented() {
        let all = catalogue();
        assert!(all.len() >= 10);
        for w in all.windows(2) {
            assert_ne!(w[0].name, w[1].name, "effect declared twice");
        }
        for e in &all {
            let (layer, effect) = e.name.split_once('.').expect("`<layer>.<effect>`");
            assert!(!layer.is_empty() && !effect.is_empty(), "{}", e.name);
            assert!(
                !e.summary.is_empty() && !e.source.is_empty(),
                "{} lacks its formula or source",
                e.name
            );
        }
    }

    #[test]
    fn defaults_switches_and_unknown_names() {
        let mut e = Effects::new(&[A, B]);
        assert!(e.is_on(&A) && !e.is_on(&B));
        e.set("env.b", true).unwrap();
        assert!(e.is_on(&B));
        let err = e.set("env.c", true).unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown effect `env.c` (known: env.a, env.b)"
        );
        let sw: EffectSwitches = [("env.a".to_owned(), false)].into();
        let e = Effects::with_switches(&[A, B], &sw).unwrap();
        assert!(!e.is_on(&A) && !e.is_on(&B));
        assert_eq!(e.to_switches().len(), 2);
    }
}
