//! Seedable simulators of positioning runs and drift logs with known effects, so the
//! diagnoses can be tested against truth. Pure: no IO; the same seed gives the same data.
//!
//! Positioning runs follow the ISO 230-2 standard test cycle: per run a + pass over the
//! targets in ascending order, then a − pass in descending order; targets irregularly
//! spaced (ISO 230-2 § 3.1: spacing varied so periodic errors are not aliased).
//! Effect definitions match the diagnosis columns (see [`super::positioning`]):
//! backlash −d·L/2 by approach direction d; reversal spike −d·h·exp(−u/λ) with u the
//! distance from the first target of the pass; cyclic A·sin(2πx/P + φ); thermal growth
//! g(t)·(offset + scale·x/1000) with g = 1 − exp(−t/τ) (temperature
//! T = 20 °C + ΔT·g when recorded); waviness A·(P₅(s) + 0.7 P₆(s)) (Legendre, s ∈ [−1, 1]).

use super::drift::first_order_lag;
use crate::axis::Axis;
use crate::basis::legendre;
use crate::datasets::{
    Channel, ChannelKind, Direction, DriftLog, PositioningRecord, PositioningRuns,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// An effect added to simulated positioning runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum PositioningEffect {
    Backlash {
        lost_motion_um: f64,
    },
    ReversalSpike {
        height_um: f64,
        decay_mm: f64,
    },
    Cyclic {
        amplitude_um: f64,
        period_mm: f64,
        phase_rad: f64,
    },
    Thermal {
        offset_um: f64,
        scale_ppm: f64,
        tau_s: f64,
        delta_t_k: f64,
    },
    Waviness {
        amplitude_um: f64,
    },
}

/// Configuration of [`simulate_positioning`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositioningSim {
    pub axis: Axis,
    pub lo_mm: f64,
    pub hi_mm: f64,
    pub n_targets: usize,
    pub n_runs: usize,
    /// Standard deviation of the reading noise, µm.
    pub noise_um: f64,
    /// Size of the smooth (cubic) rigid positioning error, µm.
    pub smooth_um: f64,
    /// Time per target reading, s (sets `t_s`).
    pub dwell_s: f64,
    /// Write `temp_c` (needs a thermal effect to vary).
    pub with_temperature: bool,
    pub effects: Vec<PositioningEffect>,
    pub seed: u64,
}

impl Default for PositioningSim {
    /// 21 targets over 0..500 mm, 5 runs, 0.5 µm noise, 15 µm smooth error, 20 s per reading.
    fn default() -> Self {
        PositioningSim {
            axis: Axis::X,
            lo_mm: 0.0,
            hi_mm: 500.0,
            n_targets: 21,
            n_runs: 5,
            noise_um: 0.5,
            smooth_um: 15.0,
            dwell_s: 20.0,
            with_temperature: false,
            effects: vec![],
            seed: 1,
        }
    }
}

/// Irregular ISO 230-2 style targets: ends exact, interior nominal ± 30 % of the spacing.
pub fn iso_targets(lo: f64, hi: f64, n: usize, rng: &mut impl Rng) -> Vec<f64> {
    let step = (hi - lo) / (n - 1) as f64;
    (0..n)
        .map(|i| {
            if i == 0 || i == n - 1 {
                lo + step * i as f64
            } else {
                lo + step * i as f64 + rng.random_range(-0.3..0.3) * step
            }
        })
        .collect()
}

/// Simulates positioning runs (module docs).
pub fn simulate_positioning(cfg: &PositioningSim) -> PositioningRuns {
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let targets = iso_targets(cfg.lo_mm, cfg.hi_mm, cfg.n_targets.max(3), &mut rng);
    let (c, h) = (0.5 * (cfg.lo_mm + cfg.hi_mm), 0.5 * (cfg.hi_mm - cfg.lo_mm));
    let poly: Vec<f64> = (0..4)
        .map(|_| cfg.smooth_um * rng.random_range(-1.0..1.0))
        .collect();
    let noise = Normal::new(0.0, cfg.noise_um.max(0.0)).expect("noise");
    let mut records = vec![];
    let mut k = 0usize;
    for run in 1..=cfg.n_runs as i64 {
        for plus in [true, false] {
            let order: Vec<f64> = if plus {
                targets.clone()
            } else {
                targets.iter().rev().copied().collect()
            };
            for &x in &order {
                let t = k as f64 * cfg.dwell_s;
                k += 1;
                let s = (x - c) / h;
                let d = if plus { 1.0 } else { -1.0 };
                let u = if plus { x - cfg.lo_mm } else { cfg.hi_mm - x };
                let mut dev = poly[0] + poly[1] * s + poly[2] * s * s + poly[3] * s * s * s;
                let mut temp = None;
                for e in &cfg.effects {
                    dev += match *e {
                        PositioningEffect::Backlash { lost_motion_um } => -0.5 * d * lost_motion_um,
                        PositioningEffect::ReversalSpike {
                            height_um,
                            decay_mm,
                        } => -d * height_um * (-u / decay_mm).exp(),
                        PositioningEffect::Cyclic {
                            amplitude_um,
                            period_mm,
                            phase_rad,
                        } => amplitude_um * (2.0 * PI * x / period_mm + phase_rad).sin(),
                        PositioningEffect::Thermal {
                            offset_um,
                            scale_ppm,
                            tau_s,
                            delta_t_k,
                        } => {
                            let g = 1.0 - (-t / tau_s).exp();
                            temp = Some(20.0 + delta_t_k * g);
                            g * (offset_um + scale_ppm * x / 1000.0)
                        }
                        PositioningEffect::Waviness { amplitude_um } => {
                            amplitude_um * (legendre(5, s).0 + 0.7 * legendre(6, s).0)
                        }
                    };
                }
                records.push(PositioningRecord {
                    axis: cfg.axis,
                    run,
                    direction: if plus {
                        Direction::Plus
                    } else {
                        Direction::Minus
                    },
                    target_mm: x,
                    deviation_um: dev + noise.sample(&mut rng),
                    t_s: Some(t),
                    temp_c: cfg
                        .with_temperature
                        .then(|| temp.unwrap_or(20.0) + 0.005 * noise.sample(&mut rng)),
                });
            }
        }
    }
    PositioningRuns { records }
}

/// Configuration of [`simulate_drift_log`]: one displacement channel `ch1_um` driven by
/// a first-order lag of the spindle heat input n/n_max, plus a temperature `t1_c` that
/// follows the same input through a slower lag, and an unrelated `t2_c` (ambient swing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DriftSim {
    pub duration_s: f64,
    pub dt_s: f64,
    pub rpm_max: f64,
    /// Steady-state growth at full speed, µm.
    pub gain_um: f64,
    pub tau_s: f64,
    pub noise_um: f64,
    pub seed: u64,
}

impl Default for DriftSim {
    /// 24 h at 30 s sampling, 6000 rpm, 20 µm gain, τ = 1.5 h, 0.1 µm noise.
    fn default() -> Self {
        DriftSim {
            duration_s: 24.0 * 3600.0,
            dt_s: 30.0,
            rpm_max: 6000.0,
            gain_um: 20.0,
            tau_s: 5400.0,
            noise_um: 0.1,
            seed: 1,
        }
    }
}

/// Simulates a drift log (see [`DriftSim`]): the spindle steps through random speeds
/// (multiples of 10 % of n_max, pauses included) held 1–4 h each.
pub fn simulate_drift_log(cfg: &DriftSim) -> DriftLog {
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let n = (cfg.duration_s / cfg.dt_s).floor() as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * cfg.dt_s).collect();
    let mut rpm = Vec::with_capacity(n);
    let mut level = 0.0;
    let mut until = 0.0;
    for &ti in &t {
        if ti >= until {
            level = if rpm.is_empty() {
                0.0
            } else {
                cfg.rpm_max * f64::from(rng.random_range(0..=10u8)) / 10.0
            };
            until = ti + rng.random_range(1.0..4.0) * 3600.0;
        }
        rpm.push(level);
    }
    let u: Vec<f64> = rpm.iter().map(|r| r / cfg.rpm_max).collect();
    let lag = first_order_lag(&t, &u, cfg.tau_s);
    let slow = first_order_lag(&t, &u, 3.0 * cfg.tau_s);
    let noise = Normal::new(0.0, cfg.noise_um).expect("noise");
    let ch1: Vec<f64> = lag
        .iter()
        .map(|v| cfg.gain_um * v + noise.sample(&mut rng))
        .collect();
    let t1: Vec<f64> = slow
        .iter()
        .map(|v| 22.0 + 4.0 * v + 0.01 * noise.sample(&mut rng))
        .collect();
    let phase = rng.random_range(0.0..2.0 * PI);
    let t2: Vec<f64> = t
        .iter()
        .map(|ti| 21.0 + 0.5 * (2.0 * PI * ti / 86400.0 + phase).sin())
        .collect();
    DriftLog {
        t_s: t,
        channels: vec![
            Channel {
                name: "spindle_rpm".into(),
                kind: ChannelKind::SpeedRpm,
                values: rpm,
            },
            Channel {
                name: "ch1_um".into(),
                kind: ChannelKind::DisplacementUm,
                values: ch1,
            },
            Channel {
                name: "t1_c".into(),
                kind: ChannelKind::TemperatureC,
                values: t1,
            },
            Channel {
                name: "t2_c".into(),
                kind: ChannelKind::TemperatureC,
                values: t2,
            },
        ],
    }
}
