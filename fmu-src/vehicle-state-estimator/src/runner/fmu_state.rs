//! The runner in the FMU state (fmi2GetFMUstate / fmi2SerializeFMUstate): the filter's own
//! running state, then what the runner keeps beside it, in a fixed order.

use estimation::registry;
use fmi_export::{StateError, StateReader, StateWriter};

use super::EstimationModel;
use super::Runner;
use crate::model_description::Variables;
use crate::state::{Sink, Source};

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    pub fn write_state(&self, writer: &mut StateWriter) {
        // The filter's own running state (Kalman-type: (x, P); the particle filter: its
        // particles and random generator), then what the runner keeps beside it.
        self.filter.save(&mut Sink(writer));
        Model::write_extra(&self.extra, writer);
        writer.f64(self.start_time);
        writer.u64(self.next_sample);
        writer.f64s(self.input.as_slice());
        writer.f64(self.nis);
        writer.i32(self.rows_used);
        writer.bool(self.started);
        for count in self.gated_samples {
            writer.u64(count);
        }
        writer.u64(self.lost_samples);
        for window in self.innovations.iter().flatten() {
            window.write(writer);
        }
        if let Some(adaptation) = &self.adaptation {
            adaptation.save(&mut Sink(writer));
        }
        if let Some(scaling) = &self.observer_scaling {
            scaling.save(&mut Sink(writer));
        }
        if let Some(monitor) = &self.innovation_monitor {
            monitor.save(&mut Sink(writer));
        }
        if let Some(noise) = &self.noise {
            noise.save(&mut Sink(writer));
        }
        writer.u64(u64::from(self.guard_samples));
        self.kinematic_check.write(writer);
        if let Some(offset) = &self.yaw_rate_offset {
            offset.write(writer);
        }
        if let Some(accelerometer) = &self.lateral_accelerometer {
            accelerometer.write(writer);
        }
        if let Some(radius) = &self.rolling_radius {
            radius.write(writer);
        }
    }

    pub fn read_state(v: &Variables, reader: &mut StateReader<'_>) -> Result<Self, StateError> {
        // Built from the parameters as at initialisation, then continued from the stored state
        // (the estimator kind is a parameter, restored first).
        let mut runner = Self::build(v, 0.0).map_err(StateError::new)?;
        let initial = Model::initial_estimate(v).map_err(StateError::new)?;
        runner.filter = registry::restore(
            runner.model.clone(),
            runner.choice,
            &runner.settings,
            &initial,
            &mut Source(reader),
        )
        .map_err(|e| StateError::new(e.0))?;
        Model::read_extra(&mut runner.extra, reader)?;
        runner.start_time = reader.f64("start time")?;
        runner.next_sample = reader.u64("next sample")?;
        reader.f64s_into(runner.input.as_mut_slice(), "driver input")?;
        runner.nis = reader.f64("nis")?;
        runner.rows_used = reader.i32("rows used")?;
        runner.started = reader.bool("started")?;
        for count in &mut runner.gated_samples {
            *count = reader.u64("gated samples")?;
        }
        runner.lost_samples = reader.u64("samples off the gyro")?;
        for window in runner.innovations.iter_mut().flatten() {
            window.read(reader)?;
        }
        if let Some(adaptation) = runner.adaptation.as_mut() {
            adaptation
                .restore(&mut Source(reader))
                .map_err(|e| StateError::new(e.0))?;
        }
        if let Some(scaling) = runner.observer_scaling.as_mut() {
            scaling
                .restore(&mut Source(reader))
                .map_err(|e| StateError::new(e.0))?;
        }
        if let Some(monitor) = runner.innovation_monitor.as_mut() {
            monitor
                .restore(&mut Source(reader))
                .map_err(|e| StateError::new(e.0))?;
        }
        if let Some(noise) = runner.noise.as_mut() {
            noise
                .restore(&mut Source(reader))
                .map_err(|e| StateError::new(e.0))?;
        }
        runner.guard_samples = u32::try_from(reader.u64("guard samples")?)
            .map_err(|_| StateError::new(String::from("guard samples out of range")))?;
        runner.kinematic_check.read(reader)?;
        if let Some(offset) = runner.yaw_rate_offset.as_mut() {
            offset.read(reader)?;
        }
        if let Some(accelerometer) = runner.lateral_accelerometer.as_mut() {
            accelerometer.read(reader)?;
        }
        if let Some(radius) = runner.rolling_radius.as_mut() {
            radius.read(reader)?;
        }
        Ok(runner)
    }
}
