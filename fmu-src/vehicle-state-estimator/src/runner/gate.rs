//! The measurement gate (`gate_measurements`), applied by the runner before each update: the
//! chi-square test per row, about the median of recent innovations for the model's model-error
//! rows, with clipping to the gate's edge, re-admission after `readmit_time`, and a re-seed when
//! a model-error row stays far off the estimate (the filter has lost the car).

use fmi_export::{StateError, StateReader, StateWriter};
use nalgebra::SMatrix;

use super::EstimationModel;
use super::Runner;
use crate::estimation_model::Sample;
use crate::sensors::Sensors;
use crate::status;

/// The measurement gate (`gate_measurements`), so that a glitch cannot pull the estimate, applied by the runner before
/// each update so that it works alike for every estimator of the registry: per row, the
/// physical plausibility of the model and the chi-square test `nu² <= threshold · S` with
/// `S = H P Hᵀ + R` of that row at the predicted estimate (for the UKF and the particle filter
/// too: it is their Gaussian approximation's linearisation). A missing row is not a rejection.
/// The model's model-error rows ([`EstimationModel::model_error_rows`]) are tested about the
/// median of their recent innovations instead, and enter clipped to the gate's edge when they
/// fail ([`InnovationWindow`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Gate {
    pub(super) test: ChiSquareGate,
    /// `INNOVATION_WINDOW_TIME` in samples, odd (see [`InnovationWindow`]).
    pub(super) window: usize,
}

impl Gate {
    /// The chi-square test of one row about the centre `centre` of its recent innovations (0
    /// for a row that is not a model-error row): `(nu − centre)² <= threshold · S`.
    fn admits(&self, innovation: f64, centre: f64, innovation_variance: f64) -> bool {
        self.test.admits(innovation - centre, innovation_variance)
    }
}

/// The chi-square test and re-admission rule of `gate_measurements`, shared by the filter's
/// rows ([`Gate`]) and a model's own tests of a measurement outside the filter (the speed
/// filter of models A and B, [`crate::speed_filter`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChiSquareGate {
    /// `gate_threshold`: 10.83 is the 99.9 % quantile of chi-square with one degree of freedom.
    pub threshold: f64,
    /// `readmit_time` in samples: a plausible row gated for this many samples in a row is a
    /// real change (the filter lost the truth, e.g. started from a wrong speed without
    /// `start_from_measurements`), and the filter is re-seeded from the measurements.
    pub readmit_samples: u64,
}

impl ChiSquareGate {
    /// `offset² <= threshold · S` for an innovation `offset` of variance `S`.
    pub fn admits(&self, offset: f64, innovation_variance: f64) -> bool {
        offset * offset <= self.threshold * innovation_variance
    }
}

/// How long a model-error row's offset from the model must last before the gate takes it for
/// the model's error, s: the window of [`InnovationWindow`], whose median moves to a persistent
/// offset after half of it (0.15 s). Measured on the harness campaigns (robustness, 15 runs,
/// 195 rows; sum of the sideslip RMSEs, 158.5 deg with the plain gate): 0.2 s 140.8, 0.3 s
/// 140.0, 0.4 s 139.3, 0.5 s 158.5 deg (model B's rows 60.0 deg up to 0.4 s, 78.5 at 0.5 s);
/// 0.3 s keeps a margin to that edge.
const INNOVATION_WINDOW_TIME: f64 = 0.3;

/// How many standard deviations of its innovation `sqrt(S)` the gyro's row may stay off the
/// predicted estimate, about 0, for [`LOST_TIME`] before the filter counts as lost
/// ([`Runner::off_the_gyro`]); the chi-square gate's 99.9 % edge is 3.3.
const LOST_SIGMAS: f64 = 5.0;

/// How long the gyro's row must stay [`LOST_SIGMAS`] off before the filter is re-seeded, s.
/// Measured on the MBDS recording's laps (harness/logs/mbds, the grip model's EKF, with and
/// without wheel speeds, the map's defaults and with the sensors' own noise): no run of
/// innovations beyond 5 sigma lasted over 12 samples (0.12 s) where the filter followed the
/// car, and the one that lost the car lasted 20 (0.2 s) before its sideslip left the car.
const LOST_TIME: f64 = 0.2;

/// The longest window in samples, bounding memory and time at fast sample rates.
const MAX_INNOVATION_WINDOW: usize = 255;

/// The recent innovations of one model-error row and their median, the centre of the row's
/// gate. A Kalman filter's innovations are zero-mean only while its model is right; a
/// persistent mean is the model's error (Mehra, 1972, "Approaches to adaptive filtering", IEEE
/// Trans. Automatic Control 17(5), the innovation-mean test), which the chi-square validation
/// gate about 0 (Bar-Shalom, Li and Kirubarajan, 2001, "Estimation with Applications to
/// Tracking and Navigation", §3.7.1) takes for a glitch sample after sample, locking the sensor
/// out while the filter follows its wrong model. So a model-error row is tested about the
/// median `m` of its last innovations, `(nu − m)² <= threshold · S`: the Hampel identifier
/// (Hampel, 1974, "The influence curve and its role in robust estimation", JASA 69(346);
/// Pearson, 2002, "Outliers in process modeling and identification", IEEE Trans. Control
/// Systems Technology 10(1)). Once an offset has lasted half the window the median sits on it
/// and the row passes; a burst of glitches shorter than half the window moves the median by no
/// more than the spread of the good innovations. A value outside the gate enters with its
/// innovation clipped to `m ± sqrt(threshold · S)`, Huber's bounded influence function on the
/// innovation (Masreliez and Martin, 1977, "Robust Bayesian estimation for the linear model and
/// robustifying the Kalman filter", IEEE Trans. Automatic Control 22(3)): a glitch of any size
/// acts as the largest sample the gate admits, and a sample of the model's error that the
/// median has not reached yet still pulls the estimate its way. The window starts with zeros
/// (the plain test until it fills) and is cleared when the filter is re-seeded.
///
/// Measured on the harness campaigns (sum of the sideslip RMSEs over 195 rows, 158.5 deg with
/// the plain gate): rejecting instead of clipping 150.7 deg, and under model error one rejected
/// gyro sample moved the yaw-rate estimate by 0.0026 rad/s, more than any sample the noise
/// gives (`tests/gate_model_error.rs`); clipping 140.0 deg. Centring on an exponentially
/// weighted mean of the innovations, each clipped to `b ± 3 sqrt(S)` before it enters, instead
/// of the median (time constant 0.2 s; both rejecting, the yaw rate the only model-error row):
/// 155.2 deg against 153.5, since it learns an offset of `D` sigma only in `D / (3 gain)`
/// samples, longer than `readmit_time` for the 13-30 sigma of a wrong tyre law in cornering.
/// Replacing a gated value by the prediction plus the median instead of clipping it made the
/// filter confirm its own prediction: 331 deg, 8 rows diverged.
#[derive(Clone, Debug)]
pub(super) struct InnovationWindow {
    /// The innovations, a ring whose oldest entry is at `next`.
    values: Vec<f64>,
    next: usize,
    /// Room for the median's selection, so that no sample allocates.
    scratch: Vec<f64>,
}

impl InnovationWindow {
    pub(super) fn new(window: usize) -> Self {
        Self {
            values: vec![0.0; window],
            next: 0,
            scratch: vec![0.0; window],
        }
    }

    /// The median of the window (its length is odd).
    fn median(&mut self) -> f64 {
        self.scratch.copy_from_slice(&self.values);
        let middle = self.scratch.len() / 2;
        *self
            .scratch
            .select_nth_unstable_by(middle, f64::total_cmp)
            .1
    }

    /// Takes one plausible, finite innovation in place of the oldest.
    fn push(&mut self, innovation: f64) {
        self.values[self.next] = innovation;
        self.next = (self.next + 1) % self.values.len();
    }

    pub(super) fn clear(&mut self) {
        self.values.fill(0.0);
        self.next = 0;
    }

    pub(super) fn write(&self, writer: &mut StateWriter) {
        writer.f64s(&self.values);
        writer.u64(self.next as u64);
    }

    pub(super) fn read(&mut self, reader: &mut StateReader<'_>) -> Result<(), StateError> {
        reader.f64s_into(&mut self.values, "innovation window")?;
        let next = reader.u64("innovation window position")?;
        self.next = usize::try_from(next)
            .ok()
            .filter(|&next| next < self.values.len())
            .ok_or_else(|| StateError::new(format!("innovation window position {next}")))?;
        Ok(())
    }
}

/// One row's innovation `nu` and its variance `S`.
#[derive(Clone, Copy, Debug)]
struct Innovation {
    value: f64,
    variance: f64,
}

/// What the gate makes of one finite row.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Verdict {
    Passed,
    /// A model-error row outside the gate enters with this innovation, at the gate's edge.
    Clipped(f64),
    Rejected,
}

impl Verdict {
    fn of(passed: bool) -> Self {
        if passed {
            Self::Passed
        } else {
            Self::Rejected
        }
    }
}

/// [`INNOVATION_WINDOW_TIME`] in samples of `sample_time`: odd, from 1 to
/// [`MAX_INNOVATION_WINDOW`].
pub(super) fn innovation_window(sample_time: f64) -> usize {
    let samples = (INNOVATION_WINDOW_TIME / sample_time).round();
    (samples.min(MAX_INNOVATION_WINDOW as f64) as usize) | 1
}

impl<Model, const N: usize, const M: usize, const U: usize> Runner<Model, N, M, U>
where
    Model: EstimationModel<N, M, U>,
{
    /// The rows that pass the gate (all rows without `gate_measurements`) and the status bits;
    /// re-seeds the filter when a plausible row has been gated for `readmit_time`.
    /// `extra_noise` is the model's extra measurement noise at the predicted estimate.
    pub(super) fn gate(
        &mut self,
        sensors: &Sensors,
        sample: &mut Sample<M, U>,
        extra_noise: Option<&SMatrix<f64, M, M>>,
    ) -> ([bool; M], i32) {
        let Some(gate) = self.gate else {
            return ([true; M], 0);
        };
        let state = *self.filter.state();
        let covariance = *self.filter.covariance();
        let std = self.measurement_std();
        let plausible = self.model.plausible(sensors, &state, self.min_speed, &std);
        let (predicted, jacobian) = self.model.measurement_and_jacobian(&state, &sample.input);
        let mut noise = self.model.measurement_noise();
        if let Some(extra) = extra_noise {
            noise += extra;
        }
        let resolvable = self
            .model
            .model_error_resolvable(&state, &sample.input, &jacobian);
        let mut passed = [true; M];
        let mut clipped = [None; M];
        let mut bits = 0;
        let mut readmit = false;
        let mut lost = false;
        let gyro = self
            .model
            .watches_gyro()
            .then(|| self.model.sensor_rows().yaw_rate);
        for row in 0..M {
            let value = sample.measurement[row];
            // A missing sample says nothing about the sensor: its count of rejected samples
            // stays as it is. Resetting it here kept a channel logged at half the filter's rate
            // (a NaN every other row) from ever reaching the re-admission time.
            if !(value.is_finite() && sample.offered[row]) {
                continue;
            }
            let h = jacobian.row(row);
            let innovation_variance = (h * covariance * h.transpose())[(0, 0)] + noise[(row, row)];
            let innovation = Innovation {
                value: value - predicted[row],
                variance: innovation_variance,
            };
            if gyro == Some(row) {
                lost = self.off_the_gyro(row, innovation, plausible[row]);
            }
            match self.judge(&gate, row, innovation, plausible[row], resolvable) {
                Verdict::Passed => {
                    self.gated_samples[row] = 0;
                    continue;
                }
                Verdict::Clipped(to) => clipped[row] = Some(predicted[row] + to),
                Verdict::Rejected => passed[row] = false,
            }
            bits |= status::ROW_GATED;
            // An implausible value is a broken sample, never a reason to re-seed.
            self.gated_samples[row] = if plausible[row] {
                self.gated_samples[row] + 1
            } else {
                0
            };
            readmit |= self.gated_samples[row] >= gate.test.readmit_samples;
        }
        if readmit || lost {
            if let Some(mut initial) = Model::measured_start(self, sensors) {
                self.model.readmitted_start(&state, &mut initial);
                if self.rebuild_at_measured(&initial) {
                    self.gated_samples = [0; M];
                    self.lost_samples = 0;
                    return (plausible, bits | status::SENSOR_READMITTED);
                }
            }
        }
        for (value, clipped) in sample.measurement.iter_mut().zip(clipped) {
            *value = clipped.unwrap_or(*value);
        }
        (passed, bits)
    }

    /// Counts the samples in a row in which the gyro's row `row`, a model-error row, is off the
    /// predicted estimate by more than [`LOST_SIGMAS`] standard deviations of its innovation (`value`,
    /// `variance`, about 0); true once they last [`LOST_TIME`]. The gate tests such a row about
    /// the median of its recent innovations and lets a value outside in at the gate's edge
    /// ([`InnovationWindow`]), which is right for a model's error of a few sigma but also lets a
    /// filter whose other states have left the car drift off a working gyro: on the MBDS
    /// recording without wheel speeds and with the accelerometer's own noise, the grip model's
    /// tyres saturated in the estimate, its yaw rate went 0.3 rad/s off the gyro in 0.2 s and
    /// then swung to 17 rad/s, the sideslip to 79° with a std of 0.2°. Past [`LOST_TIME`] the
    /// gate re-seeds the filter from the measurements, as on re-admission. Only the gyro is
    /// watched: it measures a state directly, where an accelerometer's row (model B's) carries
    /// a tyre law's error of many sigma for long in a real corner. Implausible values and rows
    /// the gate tests about 0 count nothing.
    fn off_the_gyro(&mut self, row: usize, innovation: Innovation, plausible: bool) -> bool {
        let Innovation { value, variance } = innovation;
        let watched = self.innovations[row].is_some() && plausible;
        if !(watched && value * value > LOST_SIGMAS * LOST_SIGMAS * variance) {
            self.lost_samples = 0;
            return false;
        }
        self.lost_samples += 1;
        self.lost_samples as f64 * self.sample_time >= LOST_TIME
    }

    /// The gate's verdict on one finite row. A row that is not a model-error row passes the
    /// chi-square test about 0 or is rejected. A model-error row is tested about the median of
    /// its recent innovations, and its window then takes this innovation if the value is
    /// plausible (an implausible value is a broken sample, not the model's error); a plausible
    /// value outside the gate enters clipped to the gate's edge ([`InnovationWindow`]). Where
    /// the model cannot resolve its error (`resolvable` false, see
    /// [`EstimationModel::model_error_resolvable`]) the window still takes the innovation but
    /// the row gets the plain test.
    fn judge(
        &mut self,
        gate: &Gate,
        row: usize,
        innovation: Innovation,
        plausible: bool,
        resolvable: bool,
    ) -> Verdict {
        let Innovation { value, variance } = innovation;
        let plain = || Verdict::of(plausible && gate.admits(value, 0.0, variance));
        let Some(window) = self.innovations[row].as_mut() else {
            return plain();
        };
        let centre = window.median();
        if plausible && value.is_finite() {
            window.push(value);
        }
        if !resolvable {
            return plain();
        }
        let passed = plausible && gate.admits(value, centre, variance);
        let reach = (gate.test.threshold * variance).sqrt();
        if passed || !plausible || !reach.is_finite() {
            return Verdict::of(passed);
        }
        Verdict::Clipped(centre + (value - centre).clamp(-reach, reach))
    }
}
