//! The cradle rigidity test matrix: simulated cradles whose C table tilts about its own
//! mount (about X, parallel to A, about its Y, or both; both signs; several magnitudes),
//! measured by a tracker in an arbitrary placement (frame not registered) with 2 µm noise
//! per coordinate, checked with the default options, and the check's figures compared
//! with the truth. Shared by the test (`cradle_matrix.rs`, a fast subset) and the example
//! that prints the whole table (`cargo run -p mtcal-solver --example
//! cradle_matrix`).
//!
//! The points are made three ways, so that the check is not only tested on its own
//! parameterisation:
//!
//! * `model`: the check's own model (`CradleModel::ball`);
//! * `htm`: an explicit chain of 4×4 homogeneous transforms written here, independently
//!   of the check's model, with the tilt as a rotation Rx(τ_X)·Ry(τ_Y) about the mount
//!   point between the A and C transforms;
//! * `htm+`: the chain with the tilts in the other order, Ry(τ_Y)·Rx(τ_X), taken about a
//!   mount on the actual (tilted, offset) C axis and 2 mm off it sideways (an unmodelled
//!   lever), and a C positioning error 3 µrad·sin 2C the model does not carry.
//!
//! Each seed draws its own location errors (uniform ±40 µm, ±40 µrad), ball azimuth and
//! tracker placement.
// The test uses a part of these helpers, the example all of them.
#![allow(dead_code)]

use mtcal_solver::cradle::*;
use mtcal_solver::datasets::{RotaryPoint, RotaryPointSet};
use nalgebra::{Matrix4, Vector3, Vector4};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::Normal;
use std::collections::BTreeMap;

/// The mount's height on the C axis, mm from the pivot (150 mm below it).
pub const MOUNT_MM: f64 = -150.0;
/// Tracker noise per coordinate, µm.
pub const NOISE_UM: f64 = 2.0;
/// Held-out RMS allowed against the tracker floor.
pub const FLOOR_LIMIT: f64 = 1.1;

/// How the points are made (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Maker {
    Model,
    Htm,
    HtmPlus,
}

impl Maker {
    pub const ALL: [Maker; 3] = [Maker::Model, Maker::Htm, Maker::HtmPlus];
    pub fn name(self) -> &'static str {
        match self {
            Maker::Model => "model",
            Maker::Htm => "htm",
            Maker::HtmPlus => "htm+",
        }
    }
}

/// One case of the matrix: the tilts about the mount (µrad, coefficients of sin A and
/// cos A − 1), and how the points are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// Its place in [`matrix`]: the seeds of different cases draw different cradles.
    pub id: u64,
    pub tilt_x: [f64; 2],
    pub tilt_y: [f64; 2],
    /// An A positioning error as well (rotation about the A axis, µrad, sin A and
    /// cos A − 1 coefficients).
    pub a_error: [f64; 2],
    pub maker: Maker,
}

impl Case {
    /// `X+60`, `Y-20`, `XY+150` …: which axes tilt, the sign and size of the sin A part.
    pub fn label(&self) -> String {
        let axes = match (self.tilt_x != [0.0; 2], self.tilt_y != [0.0; 2]) {
            (true, true) => "XY",
            (true, false) => "X",
            (false, true) => "Y",
            (false, false) => "none",
        };
        let lead = if self.tilt_x != [0.0; 2] {
            self.tilt_x[0]
        } else {
            self.tilt_y[0]
        };
        let cos = if self.tilt_x[1] != 0.0 || self.tilt_y[1] != 0.0 {
            " (+cos)"
        } else {
            ""
        };
        let a = if self.a_error != [0.0; 2] {
            format!(" + A error {:+}", self.a_error[0])
        } else {
            String::new()
        };
        format!("{axes} {lead:+}{cos}{a}, {}", self.maker.name())
    }

    /// The terms the truth holds.
    pub fn terms(&self) -> Vec<Term> {
        let mut v = vec![];
        if self.tilt_x != [0.0; 2] {
            v.push(Term::MountX);
        }
        if self.tilt_y != [0.0; 2] {
            v.push(Term::MountY);
        }
        if self.tilt_x != [0.0; 2] || self.tilt_y != [0.0; 2] {
            v.push(Term::MountHeight);
        }
        if self.a_error != [0.0; 2] {
            v.push(Term::APositioning);
        }
        v
    }

    /// The truth of every A-dependent parameter the check may report (reporting units).
    pub fn truth(&self, name: &str) -> f64 {
        let tilted = self.tilt_x != [0.0; 2] || self.tilt_y != [0.0; 2];
        match name {
            "tX_s" => self.tilt_x[0],
            "tX_c" => self.tilt_x[1],
            "tY_s" => self.tilt_y[0],
            "tY_c" => self.tilt_y[1],
            "z_M" if tilted => MOUNT_MM,
            "z_M" => f64::NAN,
            "s_A" => self.a_error[0],
            "k_A" => self.a_error[1],
            // A polynomial EAA(A) has no truth when the A error is harmonic.
            "e_1" | "e_2" | "e_3" if self.a_error != [0.0; 2] => f64::NAN,
            _ => 0.0,
        }
    }
}

/// The matrix: tilts about X, about Y and both (Y at half the size and opposite sign),
/// sin A only, of both signs at 20, 60 and 150 µrad, plus one case per axis with a
/// cos A − 1 part, and an A positioning error 30·sin A µrad with both tilts (the tilt
/// about Y fixing the mount height) and with the tilt about X alone (where the data
/// cannot separate them), each made by every [`Maker`].
pub fn matrix() -> Vec<Case> {
    let mut v = vec![];
    for maker in Maker::ALL {
        for m in [20.0, 60.0, 150.0] {
            for sign in [1.0, -1.0] {
                let s = sign * m;
                for (x, y) in [
                    ([s, 0.0], [0.0; 2]),
                    ([0.0; 2], [s, 0.0]),
                    ([s, 0.0], [-0.5 * s, 0.0]),
                ] {
                    v.push(Case {
                        id: v.len() as u64,
                        tilt_x: x,
                        tilt_y: y,
                        a_error: [0.0; 2],
                        maker,
                    });
                }
            }
        }
        for (x, y, a) in [
            ([60.0, -30.0], [0.0; 2], [0.0; 2]),
            ([0.0; 2], [-60.0, 30.0], [0.0; 2]),
        ] {
            v.push(Case {
                id: v.len() as u64,
                tilt_x: x,
                tilt_y: y,
                a_error: a,
                maker,
            });
        }
    }
    for maker in Maker::ALL {
        for (x, y) in [([60.0, 0.0], [-150.0, 0.0]), ([60.0, 0.0], [0.0; 2])] {
            v.push(Case {
                id: v.len() as u64,
                tilt_x: x,
                tilt_y: y,
                a_error: [30.0, 0.0],
                maker,
            });
        }
    }
    v
}

fn rx(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn ry(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        c, 0.0, s, 0.0, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn rz(t: f64) -> Matrix4<f64> {
    let (s, c) = t.sin_cos();
    Matrix4::new(
        c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}
fn tr(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    let mut m = Matrix4::identity();
    m[(0, 3)] = x;
    m[(1, 3)] = y;
    m[(2, 3)] = z;
    m
}

/// What one seed of a case draws.
struct Draw {
    location: LocationErrors,
    azimuth_deg: f64,
    placement: Matrix4<f64>,
}

fn draw(rng: &mut StdRng) -> Draw {
    let mut u = || rng.random_range(-40.0..40.0);
    let location = LocationErrors {
        ey0a_um: u(),
        ez0a_um: u(),
        eb0a_urad: u(),
        ec0a_urad: u(),
        ea0a_urad: u(),
        ex0c_um: u(),
        ey0c_um: u(),
        ea0c_urad: u(),
        eb0c_urad: u(),
        ec0c_urad: 0.0,
    };
    let azimuth_deg = rng.random_range(0.0..360.0);
    let placement = tr(
        rng.random_range(-2500.0..2500.0),
        rng.random_range(-2500.0..2500.0),
        rng.random_range(-500.0..500.0),
    ) * rz(rng.random_range(-3.0..3.0))
        * ry(rng.random_range(-0.5..0.5))
        * rx(rng.random_range(-0.5..0.5));
    Draw {
        location,
        azimuth_deg,
        placement,
    }
}

const BALL_RADIUS_MM: f64 = 150.0;
const BALL_HEIGHT_MM: f64 = 60.0;

/// The ball's position in the machine frame at (A, C) by the explicit chain (module
/// docs), mm.
fn htm_ball(case: &Case, d: &Draw, a: f64, c: f64) -> Vector3<f64> {
    let l = &d.location;
    let (um, ur) = (1e-3, 1e-6);
    let h = |ab: [f64; 2]| (ab[0] * a.sin() + ab[1] * (a.cos() - 1.0)) * ur;
    let (tx, ty) = (h(case.tilt_x), h(case.tilt_y));
    let t_a = tr(0.0, l.ey0a_um * um, l.ez0a_um * um)
        * rz(l.ec0a_urad * ur)
        * ry(l.eb0a_urad * ur)
        * rx(a + l.ea0a_urad * ur + h(case.a_error));
    let c_offset =
        tr(l.ex0c_um * um, l.ey0c_um * um, 0.0) * rx(l.ea0c_urad * ur) * ry(l.eb0c_urad * ur);
    let chain = match case.maker {
        Maker::Htm => {
            let mount = tr(0.0, 0.0, MOUNT_MM) * rx(tx) * ry(ty) * tr(0.0, 0.0, -MOUNT_MM);
            t_a * mount * c_offset * rz(c)
        }
        _ => {
            // On the actual C axis, 2 mm and −1.5 mm off it; C positioning error.
            let (mx, my) = (2.0, -1.5);
            let mount = tr(mx, my, MOUNT_MM) * ry(ty) * rx(tx) * tr(-mx, -my, -MOUNT_MM);
            t_a * c_offset * mount * rz(c + 3.0 * ur * (2.0 * c).sin())
        }
    };
    let phi = d.azimuth_deg.to_radians();
    let b = Vector4::new(
        BALL_RADIUS_MM * phi.cos(),
        BALL_RADIUS_MM * phi.sin(),
        BALL_HEIGHT_MM,
        1.0,
    );
    let p = chain * b;
    Vector3::new(p.x, p.y, p.z)
}

/// The measured points of `case` for `seed` in the tracker's placement.
pub fn points(case: &Case, seed: u64) -> RotaryPointSet {
    let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(1_000_003) ^ (case.id << 40));
    let d = draw(&mut rng);
    let model = CradleModel {
        pivot_mm: [0.0; 3],
        location: d.location,
        ball: Ball {
            radius_mm: BALL_RADIUS_MM,
            azimuth_deg: d.azimuth_deg,
            height_mm: BALL_HEIGHT_MM,
        },
        compliance: Compliance {
            centre_height_mm: MOUNT_MM,
            mount_x_urad: case.tilt_x,
            mount_y_urad: case.tilt_y,
            sin_urad: [case.a_error[0], 0.0, 0.0],
            cos_urad: [case.a_error[1], 0.0, 0.0],
            ..Compliance::default()
        },
        eaa_urad: [0.0; 3],
    };
    let noise = Normal::new(0.0, NOISE_UM * 1e-3).expect("noise");
    let mut pts = vec![];
    for k in -6..=6 {
        let a_deg = 15.0 * k as f64;
        for j in 0..18 {
            let c_deg = 20.0 * j as f64;
            let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
            let p = match case.maker {
                Maker::Model => model.ball(a, c),
                _ => htm_ball(case, &d, a, c),
            };
            let q = d.placement * Vector4::new(p.x, p.y, p.z, 1.0);
            pts.push(RotaryPoint {
                a_deg,
                c_deg,
                x_mm: q.x + rng.sample(noise),
                y_mm: q.y + rng.sample(noise),
                z_mm: q.z + rng.sample(noise),
                t_s: None,
            });
        }
    }
    RotaryPointSet {
        machine_id: Some("SIM-MATRIX".into()),
        measured_at: None,
        nominal_radius_mm: Some(BALL_RADIUS_MM),
        points: pts,
    }
}

/// A parameter's figures over the seeds of a case.
#[derive(Debug, Clone, Default)]
pub struct ParamTally {
    /// Seeds whose chosen model reported it.
    pub reported: usize,
    /// … within 2 standard uncertainties of the truth.
    pub within_2sigma: usize,
    /// … reported as not determined: not separable (from a set of terms the truth
    /// holds) or model-dependent (another model explains the data as well and puts it
    /// elsewhere).
    pub not_separable: usize,
    /// … of which model-dependent.
    pub model_dependent: usize,
    /// … without a truth to compare with.
    pub no_truth: usize,
    pub sum_value: f64,
    pub sum_std: f64,
    pub truth: f64,
    /// Signed z = (value − truth)/σ of the separable seeds with a truth: its sum and
    /// sum of squares (honest σ: mean 0, spread 1).
    pub sum_z: f64,
    pub sum_z2: f64,
    /// The seeds whose value is more than 2σ from the truth.
    pub missed: Vec<u64>,
}

impl ParamTally {
    /// Seeds with a z (separable, with a truth).
    pub fn n_z(&self) -> usize {
        self.reported - self.not_separable - self.no_truth
    }
    /// Mean and spread (sample standard deviation) of z over the seeds.
    pub fn z_mean_sd(&self) -> (f64, f64) {
        let n = self.n_z() as f64;
        let mean = self.sum_z / n;
        let var = (self.sum_z2 - n * mean * mean) / (n - 1.0);
        (mean, var.max(0.0).sqrt())
    }
}

/// The figures of one case over its seeds.
#[derive(Debug, Clone, Default)]
pub struct CaseTally {
    pub seeds: usize,
    /// Held-out RMS over the tracker floor: largest and mean, and the seeds above
    /// [`FLOOR_LIMIT`].
    pub ratio_max: f64,
    pub ratio_sum: f64,
    pub over: usize,
    /// Seeds whose lack-of-fit test rejects the chosen model at its false-alarm rate.
    pub lack_of_fit: usize,
    /// Compensation on held-out poses, RMS µm before and after (sums over seeds).
    pub before_sum: f64,
    pub after_sum: f64,
    /// The chosen models and how often.
    pub models: BTreeMap<String, usize>,
    pub params: BTreeMap<String, ParamTally>,
    /// The largest |value − truth| / σ of a separable reported parameter.
    pub worst_sigma: f64,
    /// Every check: seed, held-out / floor, the lack-of-fit test's p-value (NaN without
    /// it).
    pub checks: Vec<(u64, f64, f64)>,
}

impl CaseTally {
    pub fn add(&mut self, case: &Case, seed: u64, r: &CradleResult) {
        self.seeds += 1;
        let f = r.floor.as_ref().expect("held-out poses");
        self.ratio_max = self.ratio_max.max(f.ratio);
        if f.ratio > FLOOR_LIMIT {
            self.over += 1;
        }
        self.ratio_sum += f.ratio;
        if f.lack_of_fit.as_ref().is_some_and(|l| l.p_value < l.alpha) {
            self.lack_of_fit += 1;
        }
        self.before_sum += r.compensation.before_rms_um;
        self.after_sum += r.compensation.after_rms_um;
        *self.models.entry(short(&r.kinematics.spec)).or_default() += 1;
        let sep = r.kinematics.separability.as_ref();
        for p in &r.kinematics.parameters {
            let truth = case.truth(&p.name);
            let t = self.params.entry(p.name.clone()).or_default();
            t.truth = truth;
            t.reported += 1;
            t.sum_value += p.value;
            t.sum_std += p.std;
            // Reported as not separable: flagged so, or confounded with a set of terms
            // the truth holds (the report names it).
            let truth_terms = case.terms();
            let separable = Term::of_parameter(&p.name).is_none_or(|term| {
                sep.is_none_or(|s| {
                    s.terms.iter().any(|t| {
                        t.term == term
                            && t.separable
                            && !t
                                .confounded_with
                                .iter()
                                .any(|set| set.iter().all(|x| truth_terms.contains(x)))
                    })
                })
            });
            if truth.is_nan() {
                t.no_truth += 1;
                continue;
            }
            if !separable || p.model_dependent {
                t.not_separable += 1;
                t.model_dependent += usize::from(p.model_dependent);
                continue;
            }
            let zs = (p.value - truth) / p.std;
            t.sum_z += zs;
            t.sum_z2 += zs * zs;
            let z = zs.abs();
            self.worst_sigma = self.worst_sigma.max(z);
            if z <= 2.0 {
                t.within_2sigma += 1;
            } else {
                t.missed.push(seed);
            }
        }
    }

    pub fn ratio_mean(&self) -> f64 {
        self.ratio_sum / self.seeds.max(1) as f64
    }
}

/// Runs `case` for `seeds` and tallies the figures.
pub fn run_case(case: &Case, seeds: impl IntoIterator<Item = u64>) -> CaseTally {
    let mut tally = CaseTally::default();
    for seed in seeds {
        let r = check_cradle(&points(case, seed), &CradleOptions::default()).expect("check");
        assert_eq!(
            r.registration.frame, "best_fit",
            "the placement is arbitrary"
        );
        tally.add(case, seed, &r);
        let f = r.floor.as_ref().expect("held-out poses");
        let p = f.lack_of_fit.as_ref().map_or(f64::NAN, |l| l.p_value);
        tally.checks.push((seed, f.ratio, p));
    }
    tally
}

/// The chosen model in a few words: `mount X + mount Y`, `rigid` ….
pub fn short(spec: &ModelSpec) -> String {
    let mut v: Vec<String> = vec![];
    for (on, name) in [
        (spec.mount_x, "mount X"),
        (spec.mount_y, "mount Y"),
        (spec.a_harmonic, "A error"),
        (spec.tilt != Tilt::None, "pivot tilt"),
        (spec.axial, "shift along A"),
        (spec.lateral, "sideways shift"),
    ] {
        if on {
            v.push(name.into());
        }
    }
    if spec.eaa_order > 0 {
        v.push(format!("EAA order {}", spec.eaa_order));
    }
    if v.is_empty() {
        "rigid".into()
    } else {
        v.join(" + ")
    }
}

/// The header of [`row`]'s table.
pub const HEADER: &str = "| case | held-out / floor: mean (max); lack of fit at 1 % | compensation, held-out poses: RMS before → after, µm | tilts and mount: mean ± mean σ [truth], within 2σ of seeds reporting | other terms (truth 0): within 2σ | models chosen (seeds) |\n|---|---|---|---|---|---|";

/// A row of the table in docs/cradle.md.
pub fn row(case: &Case, t: &CaseTally) -> String {
    let mut main = vec![];
    let (mut other_in, mut other_n) = (0, 0);
    for (n, p) in &t.params {
        if p.truth == 0.0 {
            other_in += p.within_2sigma + p.not_separable;
            other_n += p.reported;
            continue;
        }
        let k = p.reported as f64;
        if p.truth.is_nan() {
            main.push(format!(
                "{n} {:.1} ± {:.1} [no truth] ×{}",
                p.sum_value / k,
                p.sum_std / k,
                p.reported
            ));
            continue;
        }
        let mut s = format!(
            "{n} {:.1} ± {:.1} [{}] {}/{}",
            p.sum_value / k,
            p.sum_std / k,
            p.truth,
            p.within_2sigma,
            p.reported
        );
        if p.n_z() > 1 {
            let (m, sd) = p.z_mean_sd();
            s += &format!(" z {m:+.1}/{sd:.1}");
        }
        if p.not_separable > 0 {
            s += &format!(" (+{} not determined)", p.not_separable);
        }
        main.push(s);
    }
    let models: Vec<String> = t.models.iter().map(|(m, k)| format!("{m} ({k})")).collect();
    format!(
        "| {} | {:.3} ({:.3}); {} | {:.1} → {:.2} | {} | {} | {} |",
        case.label(),
        t.ratio_mean(),
        t.ratio_max,
        t.lack_of_fit,
        t.before_sum / t.seeds as f64,
        t.after_sum / t.seeds as f64,
        main.join("; "),
        if other_n == 0 {
            "none reported".to_string()
        } else {
            format!("{other_in}/{other_n}")
        },
        models.join(", ")
    )
}
