//! The rigid model and the candidate effects as least-squares columns (the parent
//! module's table): Legendre columns of the smooth positioning error, each effect's
//! columns at its nonlinear parameter, and the search grid of that parameter.

use super::data::AxisData;
use crate::basis::legendre;
use crate::diagnosis::lost_motion::Profile;
use crate::diagnosis::lsq::Design;
use crate::diagnosis::series::log_grid;
use std::f64::consts::PI;

/// The candidate effects of the module table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Effect {
    Backlash,
    Spike,
    Cyclic,
    Thermal,
    ThermalTemp,
    /// A transient of the first cycle (warm-up, homing or settling after a long move).
    Transient,
}

/// Effect name of the lost motion that varies along the travel
/// ([`crate::diagnosis::lost_motion`]).
pub(super) const LOST_MOTION_PROFILE: &str = "lost_motion_profile";

impl Effect {
    pub(super) fn name(self) -> &'static str {
        match self {
            Effect::Transient => "first_cycle_transient",
            Effect::Backlash => "backlash",
            Effect::Spike => "reversal_spike",
            Effect::Cyclic => "cyclic",
            Effect::Thermal | Effect::ThermalTemp => "thermal_drift",
        }
    }
    pub(super) fn nonlinear(self) -> bool {
        matches!(
            self,
            Effect::Spike | Effect::Cyclic | Effect::Thermal | Effect::Transient
        )
    }
    pub(super) fn n_linear(self) -> usize {
        match self {
            Effect::Backlash | Effect::Spike | Effect::Transient => 1,
            _ => 2,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Term {
    pub(super) effect: Effect,
    /// λ (mm), P (mm) or τ (time units); unused otherwise.
    pub(super) theta: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct Model {
    pub(super) order: usize,
    pub(super) terms: Vec<Term>,
    /// Order K of the lost motion that varies along the travel (its columns k = 0..=K
    /// replace a constant `backlash`); `None` without it.
    pub(super) lost_motion: Option<usize>,
}

impl Model {
    /// The rigid model of polynomial order `order`.
    pub(super) fn rigid(order: usize) -> Model {
        Model {
            order,
            terms: vec![],
            lost_motion: None,
        }
    }

    pub(super) fn n_params(&self) -> usize {
        self.order
            + 1
            + self.lost_motion.map_or(0, |k| k + 1)
            + self
                .terms
                .iter()
                .map(|t| t.effect.n_linear() + usize::from(t.effect.nonlinear()))
                .sum::<usize>()
    }
}

impl AxisData {
    /// Columns of one effect at parameter `theta`.
    pub(super) fn effect_cols(&self, e: Effect, theta: f64) -> Vec<(String, Vec<f64>)> {
        let scale: Vec<f64> = self.x.iter().map(|v| v / 1000.0).collect();
        match e {
            Effect::Backlash => vec![(
                "lost_motion_um".into(),
                self.d.iter().map(|d| -0.5 * d).collect(),
            )],
            Effect::Spike => vec![(
                "height_um".into(),
                self.d
                    .iter()
                    .zip(&self.u)
                    .map(|(d, u)| -d * (-u / theta).exp())
                    .collect(),
            )],
            Effect::Cyclic => vec![
                (
                    "sin".into(),
                    self.x
                        .iter()
                        .map(|x| (2.0 * PI * x / theta).sin())
                        .collect(),
                ),
                (
                    "cos".into(),
                    self.x
                        .iter()
                        .map(|x| (2.0 * PI * x / theta).cos())
                        .collect(),
                ),
            ],
            Effect::Thermal => {
                let g: Vec<f64> = self.time.iter().map(|t| 1.0 - (-t / theta).exp()).collect();
                vec![
                    ("offset_um".into(), g.clone()),
                    (
                        "scale_ppm".into(),
                        g.iter().zip(&scale).map(|(a, b)| a * b).collect(),
                    ),
                ]
            }
            Effect::Transient => vec![(
                "size_um".into(),
                self.time
                    .iter()
                    .zip(&self.first)
                    .map(|(t, &f)| {
                        if f {
                            (-(t - self.t_first) / theta).exp()
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            )],
            Effect::ThermalTemp => {
                let dt = self.temp.clone().unwrap_or_else(|| vec![0.0; self.n()]);
                vec![
                    ("offset_um_per_k".into(), dt.clone()),
                    (
                        "scale_ppm_per_k".into(),
                        dt.iter().zip(&scale).map(|(a, b)| a * b).collect(),
                    ),
                ]
            }
        }
    }

    pub(super) fn design(&self, m: &Model) -> Design {
        let mut d = Design::new();
        for k in 0..=m.order {
            d.push(
                format!("P{k}"),
                self.s.iter().map(|&s| legendre(k, s).0).collect(),
            );
        }
        for t in &m.terms {
            for (name, col) in self.effect_cols(t.effect, t.theta) {
                d.push(format!("{}:{name}", t.effect.name()), col);
            }
        }
        if let Some(order) = m.lost_motion {
            for (name, col) in self.profile(order).columns(&self.d, &self.x) {
                d.push(format!("{LOST_MOTION_PROFILE}:{name}"), col);
            }
        }
        d
    }

    /// The lost-motion profile of order `order` on the measured travel.
    pub(super) fn profile(&self, order: usize) -> Profile {
        Profile {
            lo: self.lo,
            hi: self.hi,
            order,
        }
    }

    /// Search grid of an effect's nonlinear parameter.
    pub(super) fn grid(&self, e: Effect) -> Vec<f64> {
        let travel = self.hi - self.lo;
        match e {
            Effect::Spike => log_grid(0.25 * self.spacing, 0.5 * travel, 24),
            Effect::Cyclic => {
                // Search in frequency: from 1.5 cycles over the travel to 1/(2.2 spacing).
                let (f0, f1) = (1.5 / travel, 1.0 / (2.2 * self.spacing));
                let step = 1.0 / (6.0 * travel);
                let n = (((f1 - f0) / step).ceil() as usize).max(2);
                (0..=n)
                    .map(|i| f0 + (f1 - f0) * i as f64 / n as f64)
                    .collect()
            }
            // From one cycle (a shorter one is the first-cycle transient's) to five times
            // the recording.
            Effect::Thermal => {
                let dur = self.time.iter().fold(0.0f64, |a, &b| a.max(b)).max(1.0);
                log_grid((dur / 30.0).max(self.first_duration), 5.0 * dur, 24)
            }
            // From a quarter of a record's step (a transient at the first reading only) to
            // five times the first cycle (an offset of the whole cycle).
            Effect::Transient => log_grid(0.25 * self.first_step, 5.0 * self.first_duration, 24),
            _ => vec![0.0],
        }
    }

    /// θ from a searched value (the cyclic search runs in frequency).
    pub(super) fn theta_of(e: Effect, v: f64) -> f64 {
        if e == Effect::Cyclic { 1.0 / v } else { v }
    }
}
