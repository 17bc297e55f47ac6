//! A small model for the plumbing's own tests: an integrator `y' = gain * u` stepped in internal
//! steps of `internal_step`, with one variable of each kind the setters treat differently
//! (bounded Real parameter and input, plain Integer, enumeration). Hand-written where an FMU
//! crate includes the table generated from its modelDescription.xml.

use fmi_export::{
    Causality, CoSimulationModel, Fmi3Kind, Fmi3Variable, InstantiationContext, StateError,
    StateReader, StateWriter, StepOutcome, ValueType, Variability, VariableInfo, VariableStore,
};

pub mod vr {
    pub const INTERNAL_STEP: u32 = 0;
    pub const GAIN: u32 = 1;
    pub const U: u32 = 2;
    pub const Y: u32 = 3;
    pub const ORDER: u32 = 0;
    pub const MODE: u32 = 1;
    pub const TIME: u32 = 1000;
    pub const Y_TABLE: u32 = 1001;
}

const fn real(
    name: &'static str,
    value_reference: u32,
    causality: Causality,
    variability: Variability,
    min: f64,
    max: f64,
) -> VariableInfo {
    VariableInfo {
        name,
        value_reference,
        value_type: ValueType::Real,
        causality,
        variability,
        min,
        max,
        allowed_values: &[],
    }
}

const fn integer(
    name: &'static str,
    value_reference: u32,
    min: f64,
    max: f64,
    allowed_values: &'static [i32],
) -> VariableInfo {
    VariableInfo {
        name,
        value_reference,
        value_type: ValueType::Integer,
        causality: Causality::Parameter,
        variability: Variability::Fixed,
        min,
        max,
        allowed_values,
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Variables {
    pub reals: [f64; 4],
    pub integers: [i32; 2],
}

impl VariableStore for Variables {
    fn variable_row(_: ValueType, _: u32) -> Option<usize> {
        // The plumbing falls back to a binary search of VARIABLES.
        None
    }
    fn real(&self, value_reference: u32) -> Option<f64> {
        self.reals.get(value_reference as usize).copied()
    }
    fn set_real(&mut self, value_reference: u32, value: f64) -> bool {
        self.reals
            .get_mut(value_reference as usize)
            .map(|slot| *slot = value)
            .is_some()
    }
    fn integer(&self, value_reference: u32) -> Option<i32> {
        self.integers.get(value_reference as usize).copied()
    }
    fn set_integer(&mut self, value_reference: u32, value: i32) -> bool {
        self.integers
            .get_mut(value_reference as usize)
            .map(|slot| *slot = value)
            .is_some()
    }
    fn boolean(&self, _: u32) -> Option<bool> {
        None
    }
    fn set_boolean(&mut self, _: u32, _: bool) -> bool {
        false
    }
    fn write_state(&self, writer: &mut StateWriter) {
        self.reals.iter().for_each(|&value| writer.f64(value));
        self.integers.iter().for_each(|&value| writer.i32(value));
    }
    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        for value in &mut self.reals {
            *value = reader.f64("real")?;
        }
        for value in &mut self.integers {
            *value = reader.i32("integer")?;
        }
        Ok(())
    }
}

#[derive(Debug, Clone)]
pub struct Toy {
    variables: Variables,
    internal_steps_taken: u64,
}

impl CoSimulationModel for Toy {
    type Variables = Variables;
    const MODEL_IDENTIFIER: &'static str = "Toy";
    const GUID: &'static str = "{toy-guid}";
    const VARIABLES: &'static [VariableInfo] = &[
        real(
            "internal_step",
            vr::INTERNAL_STEP,
            Causality::Parameter,
            Variability::Fixed,
            0.0,
            1.0,
        ),
        real(
            "gain",
            vr::GAIN,
            Causality::Parameter,
            Variability::Tunable,
            0.0,
            10.0,
        ),
        real(
            "u",
            vr::U,
            Causality::Input,
            Variability::Continuous,
            -5.0,
            5.0,
        ),
        real(
            "y",
            vr::Y,
            Causality::Output,
            Variability::Continuous,
            f64::NEG_INFINITY,
            f64::INFINITY,
        ),
        integer("order", vr::ORDER, 1.0, 4.0, &[]),
        integer("mode", vr::MODE, 1.0, 2.0, &[1, 2]),
    ];
    const LOG_CATEGORIES: &'static [&'static str] = &[
        "logEvents",
        "logStatusWarning",
        "logStatusDiscard",
        "logStatusError",
        "logStatusFatal",
        "logAll",
    ];
    const MAX_INTERNAL_STEPS: u64 = 1000;
    // FMI 3: the independent variable, and a 2-by-3 array holding y scaled by its row-major
    // index, so that a test sees each element land in its place.
    const FMI3_VARIABLES: &'static [Fmi3Variable] = &[
        Fmi3Variable {
            name: "time",
            value_reference: vr::TIME,
            kind: Fmi3Kind::Time,
        },
        Fmi3Variable {
            name: "y_table",
            value_reference: vr::Y_TABLE,
            kind: Fmi3Kind::Float64 {
                dimensions: &[2, 3],
            },
        },
    ];
    const OUTPUT_DEPENDENCIES: &'static [(u32, &'static [u32])] =
        &[(vr::Y, &[]), (vr::Y_TABLE, &[])];

    fn fmi3_float64(&self, value_reference: u32, values: &mut [f64]) -> bool {
        if value_reference != vr::Y_TABLE {
            return false;
        }
        let y = self.variables.reals[vr::Y as usize];
        for (index, value) in values.iter_mut().enumerate() {
            *value = y * index as f64;
        }
        true
    }

    fn instantiate(_: &InstantiationContext) -> Self {
        Self {
            variables: Variables {
                reals: [1e-3, 1.0, 0.0, 0.0],
                integers: [1, 1],
            },
            internal_steps_taken: 0,
        }
    }
    fn variables(&self) -> &Variables {
        &self.variables
    }
    fn variables_mut(&mut self) -> &mut Variables {
        &mut self.variables
    }
    fn initialize(&mut self, _: f64) -> Result<(), String> {
        self.variables.reals[vr::Y as usize] = 0.0;
        Ok(())
    }
    fn internal_step_size(&self) -> Option<f64> {
        Some(self.variables.reals[vr::INTERNAL_STEP as usize])
    }
    fn do_step(&mut self, _: f64, step_size: f64) -> StepOutcome {
        let [internal_step, gain, u, _] = self.variables.reals;
        let u = if u.is_finite() { u } else { 0.0 };
        let mut remaining = step_size;
        while remaining > 0.0 {
            let dt = remaining.min(internal_step);
            self.variables.reals[vr::Y as usize] += gain * u * dt;
            remaining -= dt;
            self.internal_steps_taken += 1;
        }
        StepOutcome::Ok
    }
    fn write_state(&self, writer: &mut StateWriter) -> Result<(), String> {
        writer.u64(self.internal_steps_taken);
        Ok(())
    }
    fn read_state(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        self.internal_steps_taken = reader.u64("internal steps taken")?;
        Ok(())
    }
}

fmi_export::export_fmi2!(Toy);
fmi_export::export_fmi3!(Toy);

/// A fresh instance of the toy, driven through its C ABI.
pub fn slave() -> fmi_export::testing::Slave {
    let api = fmi_export::fmi2_api_of!(crate::toy);
    fmi_export::testing::Slave::instantiate(api, "toy", Toy::GUID).expect("instantiate")
}
