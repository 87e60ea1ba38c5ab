//! Helpers shared by the stepwise tests: simulated machines and the reported values
//! paired with the truth.
// Each test binary uses a different part of these helpers.
#![allow(dead_code)]

use mtcal_solver::basis::PolyErrors;
use mtcal_solver::identification::{IdentificationResult, IdentifyOptions, Method, identify};
use mtcal_solver::session::Session;
use mtcal_solver::simulate::{Plan, SimOptions, Truth, random_truth, simulate};
use mtcal_solver::terms::Term;

/// As in identification_truth.rs: enough samples per pass, fast suite.
pub const RATE_HZ: f64 = 10.0;

/// A random machine (random_truth) with its nine angular functions set to zero.
pub fn without_angles(seed: u64) -> PolyErrors {
    let mut errors = random_truth(seed);
    for t in Term::all() {
        if t.is_angular() {
            errors.coefficients.remove(&t.name());
        }
    }
    errors
}

/// The session the plan records on the machine (noise 0.15 µm, 10 Hz).
pub fn record(errors: &PolyErrors, plan: Plan, seed: u64) -> (Session, Truth) {
    let opts = SimOptions {
        plan,
        seed,
        sample_rate_hz: RATE_HZ,
        ..Default::default()
    };
    let out = simulate(errors, &opts).expect("simulation");
    (out.session, out.truth)
}

pub fn run(session: &Session, method: Method) -> IdentificationResult {
    let opts = IdentifyOptions {
        method,
        ..Default::default()
    };
    identify(session, &opts).unwrap()
}

/// One reported grid value with its truth.
pub struct Pair {
    pub name: String,
    pub q_mm: f64,
    pub value: f64,
    pub truth: f64,
    pub std: f64,
    /// Accuracy floor of the identification tests: 0.1 µm or 1 µrad.
    pub floor: f64,
}

impl Pair {
    /// |value − truth| within max(floor, k·σ).
    pub fn within(&self, k: f64) -> bool {
        (self.value - self.truth).abs() <= self.floor.max(k * self.std)
    }
    pub fn ratio(&self) -> f64 {
        (self.value - self.truth).abs() / self.floor.max(3.0 * self.std)
    }
}

/// Every reported value of term `name` (all terms when `None`) and every reported
/// squareness, paired with the truth.
pub fn pairs(r: &IdentificationResult, truth: &Truth, name: Option<&str>) -> Vec<Pair> {
    let mut out = Vec::new();
    for (n, t) in &r.terms {
        if name.is_some_and(|m| m != n) {
            continue;
        }
        let tt = &truth.terms[n];
        for (k, q) in t.positions_mm.iter().enumerate() {
            let j = tt.positions_mm.iter().position(|p| p == q).unwrap();
            out.push(Pair {
                name: n.clone(),
                q_mm: *q,
                value: t.values[k],
                truth: tt.values[j],
                std: t.std[k],
                floor: if t.unit == "um" { 0.1 } else { 1.0 },
            });
        }
    }
    if name.is_none() {
        for (n, s) in &r.squareness {
            if let (Some(v), Some(sd)) = (s.value_urad, s.std_urad) {
                out.push(Pair {
                    name: n.clone(),
                    q_mm: 0.0,
                    value: v,
                    truth: truth.squareness_urad[n],
                    std: sd,
                    floor: 1.0,
                });
            }
        }
    }
    out
}
