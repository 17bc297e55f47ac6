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
