//! Simulated cradle measurements: a known [`CradleModel`] (location errors, optional
//! compliance), commanded A poses × C angles, isotropic Gaussian tracker noise. Pure and
//! seedable: the same options and seed give the same points.

use super::model::{Ball, Compliance, CradleModel, LocationErrors};
use crate::datasets::{RotaryPoint, RotaryPointSet};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::Normal;
use serde::{Deserialize, Serialize};

/// What to simulate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CradleSimulation {
    pub truth: CradleModel,
    /// Commanded A poses, degrees.
    pub a_deg: Vec<f64>,
    /// Commanded C angles at every A pose, degrees.
    pub c_deg: Vec<f64>,
    /// Tracker noise, standard deviation per coordinate, µm.
    pub noise_um: f64,
    pub seed: u64,
}

/// How the example cradle deflects with A.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Deflection {
    /// Rigid connection.
    Rigid,
    /// The table tilts with A about the pivot (up to ~90 µrad, observable form).
    Pivot,
    /// The C table tilts with A about its own mount 150 mm below the pivot, about X
    /// (parallel to A) by 60·sin A µrad and about its Y by −25·sin A µrad.
    Mount,
}

impl CradleSimulation {
    /// An example cradle: A from −90° to 90° step 15°, C every 20°, ball 150 mm from the
    /// C axis and 60 mm above the pivot, location errors of tens of µm and µrad, tracker
    /// noise 2 µm. With `compliant`, the table deflects by up to ~90 µrad with A
    /// (observable form, see [`Compliance::from_observable`]).
    pub fn example(compliant: bool, seed: u64) -> Self {
        Self::example_with(
            if compliant {
                Deflection::Pivot
            } else {
                Deflection::Rigid
            },
            seed,
        )
    }

    /// The example cradle with the given deflection (see [`Deflection`]).
    pub fn example_with(deflection: Deflection, seed: u64) -> Self {
        let truth = CradleModel {
            pivot_mm: [0.0, 0.0, 0.0],
            location: LocationErrors {
                ey0a_um: 25.0,
                ez0a_um: -40.0,
                eb0a_urad: 30.0,
                ec0a_urad: -20.0,
                ea0a_urad: 15.0,
                ex0c_um: 35.0,
                ey0c_um: -18.0,
                ea0c_urad: 10.0,
                eb0c_urad: 45.0,
                ec0c_urad: 0.0,
            },
            ball: Ball {
                radius_mm: 150.0,
                azimuth_deg: 3.0,
                height_mm: 60.0,
            },
            compliance: match deflection {
                Deflection::Rigid => Compliance::default(),
                Deflection::Pivot => Compliance::from_observable([8.0, -5.0, 60.0, -25.0]),
                Deflection::Mount => Compliance {
                    centre_height_mm: -150.0,
                    mount_x_urad: [60.0, 0.0],
                    mount_y_urad: [-25.0, 0.0],
                    ..Compliance::default()
                },
            },
            eaa_urad: [0.0; 3],
        };
        CradleSimulation {
            truth,
            a_deg: (-6..=6).map(|k| 15.0 * k as f64).collect(),
            c_deg: (0..18).map(|k| 20.0 * k as f64).collect(),
            noise_um: 2.0,
            seed,
        }
    }
}

/// Generates the measured point set of `sim` (machine id `SIM-CRADLE`).
pub fn simulate_cradle(sim: &CradleSimulation) -> RotaryPointSet {
    let mut rng = StdRng::seed_from_u64(sim.seed);
    let noise = Normal::new(0.0, sim.noise_um.max(0.0) * 1e-3).expect("finite noise");
    let mut points = Vec::with_capacity(sim.a_deg.len() * sim.c_deg.len());
    for &a in &sim.a_deg {
        for &c in &sim.c_deg {
            let p = sim.truth.ball(a.to_radians(), c.to_radians());
            points.push(RotaryPoint {
                a_deg: a,
                c_deg: c,
                x_mm: p.x + rng.sample(noise),
                y_mm: p.y + rng.sample(noise),
                z_mm: p.z + rng.sample(noise),
                t_s: None,
            });
        }
    }
    RotaryPointSet {
        machine_id: Some("SIM-CRADLE".into()),
        measured_at: None,
        nominal_radius_mm: Some(sim.truth.ball.radius_mm),
        points,
    }
}
