//! The loops shared by the report's tests.

use datasets::simulate::{Controller, PlantPreset, PlantSpec, Scenario, Setpoint, SimulatedLoop};
use stiction_models::Kano;

/// A self-regulating loop in a limit cycle through a sticky valve (slow plant, PI 0.3/0.1,
/// Kano S = 4, J = 1, constant set point, 1000 samples, seed 1; the loop of the CLI's
/// detection tests).
pub fn sticky_simulation() -> SimulatedLoop {
    Scenario {
        plant: PlantSpec::Preset(PlantPreset::Slow),
        controller: Controller { kc: 0.3, ki: 0.1 },
        setpoint: Setpoint::constant(),
        valve: Box::new(Kano::params().s(4.0).j(1.0).check().expect("valid")),
        noise_sigma: 0.02,
        samples: 1000,
        warmup: 500,
        seed: 1,
        ..Scenario::default()
    }
    .simulate()
    .expect("simulates")
}
