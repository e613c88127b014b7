//! Named, switchable physical effects.
//!
//! Every physical effect a model applies is a named unit (`env.fog_extinction`, `space.multipath`,
//! `lidar.range_walk`, ...) that can be switched on and off by name, so the consistency workflow can
//! attribute a model/measurement discrepancy to a missing effect and show the error fall when it is
//! enabled. Each module declares its effects as [`EffectInfo`] constants (name, default, formula and
//! source); an [`Effects`] set holds the switches of one model instance.
//!
//! This module is the mechanism only and names no model: each module lists its own effects
//! (`environment::effects()`, `space::EFFECTS`, `lidar::effects()`, ...) and the registry
//! (`crate::registry::catalogue`) concatenates them.

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
    /// The effect this one refines (its stage's parent switch): it applies only while that one is
    /// on too, e.g. `lidar.fog_extinction` requires `env.fog_extinction`. [`Effects::is_on`]
    /// answers for the chain; no call site writes `env.* && sensor.*` itself.
    pub requires: Option<&'static str>,
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

    /// Whether an effect applies: its own switch is on and so is every effect it requires
    /// ([`EffectInfo::requires`], followed up the chain; a required effect this set does not
    /// declare counts as on). Panics on a name that was never declared: that is a programming
    /// error in the model, not a user input.
    pub fn is_on(&self, info: &EffectInfo) -> bool {
        let own = *self
            .on
            .get(info.name)
            .unwrap_or_else(|| panic!("effect `{}` is not declared", info.name));
        let mut parent = info.requires;
        let mut hops = 0;
        while own && let Some(name) = parent {
            match (self.on.get(name), self.known.get(name)) {
                (Some(false), _) => return false,
                (_, Some(p)) if hops < 8 => parent = p.requires,
                _ => break,
            }
            hops += 1;
        }
        own
    }

    /// The effect's own switch, whatever the effects it requires say.
    pub fn switch(&self, info: &EffectInfo) -> bool {
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
        requires: None,
    };
    const B: EffectInfo = EffectInfo {
        name: "env.b",
        default_on: false,
        summary: "b",
        source: "s",
        requires: None,
    };

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
