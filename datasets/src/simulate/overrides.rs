//! Changes to a [`Scenario`] as `stiction simulate`'s flags give them (`--plant`, `--delay`,
//! `--valve`, `--param`, `--kc`, `--ki`, `--disturbance`, `--noise`, `--samples`, `--warmup`,
//! `--seed`), applied in one place with messages naming the flag.

use stiction_models::find_model;

use super::{Disturbance, PlantPreset, PlantSpec, Scenario};

/// The largest controller gain `--kc` / `--ki` accept: gains beyond any process's are a typo,
/// not a tuning (1e308 overflows the simulation).
pub const MAX_GAIN: f64 = 1e6;

/// What to change in a scenario; `None` (or no parameters) keeps the scenario's value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// A plant preset by name (`paper`, `slow`).
    pub plant: Option<String>,
    /// The plant's dead time, samples.
    pub delay: Option<usize>,
    /// A stiction model by its registered name.
    pub valve: Option<String>,
    /// Valve parameters `NAME=value` (on the named model, or on the scenario's valve).
    pub params: Vec<(String, f64)>,
    /// Controller gain.
    pub kc: Option<f64>,
    /// Controller integral gain.
    pub ki: Option<f64>,
    /// Amplitude of the paper's nonstationary disturbance (0 removes it).
    pub disturbance: Option<f64>,
    /// Measurement noise standard deviation.
    pub noise: Option<f64>,
    /// Samples kept.
    pub samples: Option<usize>,
    /// Warm-up samples discarded.
    pub warmup: Option<usize>,
    /// Random seed.
    pub seed: Option<u64>,
}

/// A change that cannot be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OverrideError {
    /// No such plant preset.
    #[error("unknown plant {0:?}; presets are paper, slow")]
    UnknownPlant(String),
    /// The valve's model or a parameter was refused.
    #[error(transparent)]
    Valve(#[from] stiction_models::StictionError),
    /// A controller gain that is not finite or beyond [`MAX_GAIN`].
    #[error(
        "{flag} {value:e}: expected a finite controller gain of magnitude at most {MAX_GAIN:e}"
    )]
    Gain {
        /// `--kc` or `--ki`.
        flag: &'static str,
        /// The value given.
        value: f64,
    },
}

impl Scenario {
    /// Apply `o` (the scenario is left unchanged on error). The valve: a new model by name, or
    /// the configured one with some parameters changed. Call [`Scenario::validate`] after.
    pub fn apply(&mut self, o: &Overrides) -> Result<(), OverrideError> {
        for (flag, v) in [("--kc", o.kc), ("--ki", o.ki)] {
            if let Some(value) = v.filter(|v| !(v.is_finite() && v.abs() <= MAX_GAIN)) {
                return Err(OverrideError::Gain { flag, value });
            }
        }
        let mut sc = self.clone();
        if let Some(name) = &o.plant {
            let preset = PlantPreset::parse(name)
                .ok_or_else(|| OverrideError::UnknownPlant(name.clone()))?;
            sc.plant = PlantSpec::Preset(preset);
        }
        if let Some(d) = o.delay {
            let mut plant = sc.plant.plant();
            plant.delay = d;
            sc.plant = PlantSpec::Explicit(plant);
        }
        if o.valve.is_some() || !o.params.is_empty() {
            let name = o
                .valve
                .clone()
                .unwrap_or_else(|| sc.valve.name().to_string());
            let entry = find_model(&name)?;
            let mut pairs: Vec<(String, f64)> = Vec::new();
            if entry.name == sc.valve.name() {
                pairs.extend(
                    entry
                        .params
                        .iter()
                        .map(|p| p.name.to_string())
                        .zip(sc.valve.param_values()),
                );
            }
            pairs.extend(o.params.iter().cloned());
            sc.valve = entry.build_named(&pairs)?;
        }
        if let Some(kc) = o.kc {
            sc.controller.kc = kc;
        }
        if let Some(ki) = o.ki {
            sc.controller.ki = ki;
        }
        if let Some(a) = o.disturbance {
            sc.disturbances
                .retain(|d| !matches!(d, Disturbance::Paper { .. }));
            if a != 0.0 {
                sc.disturbances.push(Disturbance::Paper { a });
            }
        }
        if let Some(n) = o.noise {
            sc.noise_sigma = n;
        }
        if let Some(n) = o.samples {
            sc.samples = n;
        }
        if let Some(n) = o.warmup {
            sc.warmup = n;
        }
        if let Some(n) = o.seed {
            sc.seed = n;
        }
        *self = sc;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_change_what_they_name_and_refuse_what_cannot_work() -> Result<(), OverrideError> {
        let mut sc = Scenario::default();
        sc.apply(&Overrides {
            params: vec![("S".into(), 5.0)],
            seed: Some(9),
            disturbance: Some(0.25),
            ..Overrides::default()
        })?;
        assert_eq!(sc.valve.param_values(), vec![5.0, 0.0]);
        assert_eq!(sc.seed, 9);
        assert_eq!(sc.disturbances, vec![Disturbance::Paper { a: 0.25 }]);
        let before = sc.to_json();
        let bad = Overrides {
            plant: Some("fast".into()),
            seed: Some(1),
            ..Overrides::default()
        };
        assert!(matches!(
            sc.apply(&bad),
            Err(OverrideError::UnknownPlant(_))
        ));
        assert_eq!(sc.to_json(), before, "unchanged on error");
        let gain = Overrides {
            kc: Some(1e308),
            ..Overrides::default()
        };
        assert!(sc
            .apply(&gain)
            .is_err_and(|e| e.to_string().starts_with("--kc")));
        Ok(())
    }
}
