//! The recording: per window of [`WINDOW_SAMPLES`] samples its start time and per joint the
//! largest |r_j| with the motion features of that sample, and the mean of r_j (signed: what a
//! contact holds, noise averages away; [`super::screen`]).

use nalgebra::SVector;

use super::{FEATURES, WINDOW_SAMPLES};
use crate::envelope::MotionFeatures;

/// One recorded window.
#[derive(Debug, Clone, Copy)]
pub(super) struct Window<const N: usize> {
    /// Time of the window's first sample \[s\] (the caller's clock).
    pub(super) time_s: f64,
    /// Mean of r_j over the window \[Nm\] (signed).
    pub(super) mean: [f32; N],
    pub(super) peak: [f32; N],
    pub(super) features: [[f32; N]; FEATURES],
}

/// Records a residual without contact with its motion features (not real-time: it grows by
/// ≈ 30 bytes per joint and window, 75 MB for an hour of 7 joints at 1 kHz).
#[derive(Debug, Clone)]
pub struct EnvelopeRecorder<const N: usize> {
    pub(super) windows: Vec<Window<N>>,
    current: Option<Window<N>>,
    in_window: usize,
    /// Sum of r over the current window \[Nm\].
    sum: SVector<f64, N>,
    pub(super) samples: u64,
    pub(super) peak: SVector<f64, N>,
    pub(super) max_speed: SVector<f64, N>,
    pub(super) max_acceleration: SVector<f64, N>,
}

impl<const N: usize> Default for EnvelopeRecorder<N> {
    fn default() -> Self {
        Self::new()
    }
}

fn features_of<const N: usize>(f: &MotionFeatures<N>) -> [[f32; N]; FEATURES] {
    std::array::from_fn(|k| std::array::from_fn(|j| f.regressors(j)[k + 1] as f32))
}

impl<const N: usize> EnvelopeRecorder<N> {
    /// An empty recording.
    pub fn new() -> Self {
        Self {
            windows: Vec::new(),
            current: None,
            in_window: 0,
            sum: SVector::zeros(),
            samples: 0,
            peak: SVector::zeros(),
            max_speed: SVector::zeros(),
            max_acceleration: SVector::zeros(),
        }
    }

    /// Adds one sample at `time_s` \[s\] (any clock that increases; it names the time of a
    /// contact-like onset): residual `residual` \[Nm\] and the motion features the detector used
    /// with it. Non-finite samples are skipped.
    pub fn push(&mut self, time_s: f64, residual: &SVector<f64, N>, features: &MotionFeatures<N>) {
        let finite = time_s.is_finite()
            && residual.iter().all(|x| x.is_finite())
            && features_of(features)
                .iter()
                .all(|f| f.iter().all(|x| x.is_finite()));
        if !finite {
            return;
        }
        self.samples += 1;
        self.peak = self.peak.sup(&residual.abs());
        self.max_speed = self.max_speed.sup(&features.speed);
        self.max_acceleration = self.max_acceleration.sup(&features.acceleration.abs());
        self.sum += residual;
        let now = Window {
            time_s,
            mean: [0.0; N],
            peak: std::array::from_fn(|j| residual[j].abs() as f32),
            features: features_of(features),
        };
        match &mut self.current {
            None => self.current = Some(now),
            Some(w) => {
                // Per joint, the sample of the window's largest |r_j| with its own features:
                // what the scheduled threshold saw at that peak.
                for j in 0..N {
                    if now.peak[j] > w.peak[j] {
                        w.peak[j] = now.peak[j];
                        for k in 0..FEATURES {
                            w.features[k][j] = now.features[k][j];
                        }
                    }
                }
            }
        }
        self.in_window += 1;
        if self.in_window == WINDOW_SAMPLES {
            if let Some(mut w) = self.current.take() {
                w.mean = std::array::from_fn(|j| (self.sum[j] / WINDOW_SAMPLES as f64) as f32);
                self.windows.push(w);
            }
            self.in_window = 0;
            self.sum = SVector::zeros();
        }
    }

    /// Samples recorded.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Largest |r_j| recorded \[Nm\].
    pub fn peak(&self) -> &SVector<f64, N> {
        &self.peak
    }
}
