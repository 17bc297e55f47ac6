//! A first-order Gauss-Markov process sampled every `T`, the model of every slowly drifting
//! sensor error the FMU learns (the accelerometers' offsets, the gyro's offset, the lateral
//! accelerometer's gain): `x(k+1) = a x(k) + w`, `a = exp(−T/τ)`, `var(w) = σ² (1 − a²)`, so
//! that the stationary variance stays `σ²` (Brown and Hwang, Introduction to Random Signals and
//! Applied Kalman Filtering, 4th ed. 2012, §2.9).

/// One process's discretisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussMarkov {
    /// `a = exp(−T/τ)`.
    pub decay: f64,
    /// `σ² (1 − a²)`.
    pub process_variance: f64,
}

impl GaussMarkov {
    /// The process of stationary variance `stationary_variance` and correlation time
    /// `time_constant`, sampled every `sample_time`.
    pub fn new(stationary_variance: f64, sample_time: f64, time_constant: f64) -> Self {
        let decay = (-sample_time / time_constant).exp();
        Self {
            decay,
            process_variance: stationary_variance * (1.0 - decay * decay),
        }
    }

    /// The variance one sample later, `a² P + σ² (1 − a²)`.
    pub fn predicted_variance(&self, variance: f64) -> f64 {
        self.decay * self.decay * variance + self.process_variance
    }
}

/// The variance per sample of white noise with the low-frequency spectral density of
/// correlated errors, `2 Σ τᵢ σᵢ² / T` from `time_variance` = `Σ τᵢ σᵢ²` (each error a
/// first-order Gauss-Markov process of std `σᵢ` and correlation time `τᵢ`; Brown and Hwang,
/// §2.9): how each learner takes the slowly varying error of its reference as measurement
/// noise.
pub fn white_equivalent(time_variance: f64, sample_time: f64) -> f64 {
    2.0 * time_variance / sample_time
}

/// A scalar Gauss-Markov state's estimate: its mean and variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalarEstimate {
    pub mean: f64,
    pub variance: f64,
}

impl ScalarEstimate {
    /// One sample of `process`: the prediction, then, where `measurement` gives a value `z` of
    /// the state with its noise variance, the scalar Kalman update in Joseph form (000:
    /// 4.64-4.75 in one dimension), unless the innovation lies outside `gate_sigmas` standard
    /// deviations (a glitch teaches nothing). Returns whether the update was taken.
    pub fn step(
        &mut self,
        process: &GaussMarkov,
        measurement: Option<(f64, f64)>,
        gate_sigmas: f64,
    ) -> bool {
        let prior = process.predicted_variance(self.variance);
        self.mean *= process.decay;
        self.variance = prior;
        let Some((z, noise)) = measurement else {
            return false;
        };
        let innovation = z - self.mean;
        let innovation_variance = prior + noise;
        let bound = gate_sigmas * gate_sigmas * innovation_variance;
        // a NaN compares as outside
        let inside = (innovation * innovation)
            .partial_cmp(&bound)
            .is_some_and(std::cmp::Ordering::is_le);
        if !inside {
            return false;
        }
        let gain = prior / innovation_variance;
        self.mean += gain * innovation;
        self.variance = (1.0 - gain) * (1.0 - gain) * prior + gain * gain * noise;
        true
    }
}
