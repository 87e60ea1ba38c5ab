//! How the rotation vector depends on A: rigid (constant) versus compliant
//! (r(A) = r₀ + s·sin A + k·cos A, the form of gravity loading of a tilting table), chosen
//! as fits of the per-pose rotation vectors with their leave-one-pose-out prediction
//! errors. These figures describe the patent's vectors; the decision between the
//! models is taken on the kinematic model ([`super::identify`]), because any error of
//! the A axis fitted through the centres (and of the reference frame) enters every
//! rotation vector exactly as a sin A / cos A pattern: a rigid cradle measured with
//! noise shows an apparent "compliance" of the size of the axis fit's uncertainty.
//!
//! Each model is a linear least-squares fit of the per-pose rotation vectors (three
//! components share the design matrix `[1]` or `[1, sin A, cos A]`), solved by SVD. The
//! held-out error of a model is √(mean over poses of |r̂₋ᵢ(Aᵢ) − rᵢ|²), r̂₋ᵢ fitted without
//! pose i. The compliant fit needs at least 5 poses (4 left in each fold for 3
//! coefficients).

use nalgebra::{DMatrix, Vector3};
use serde::{Deserialize, Serialize};

/// The two candidate models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "lowercase")]
pub enum Dependence {
    Rigid,
    Compliant,
}

/// One fitted model of r(A), µrad.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DependenceFit {
    pub model: Dependence,
    pub r0_urad: [f64; 3],
    /// Compliant only: coefficients of sin A and cos A.
    pub sin_urad: Option<[f64; 3]>,
    pub cos_urad: Option<[f64; 3]>,
    /// RMS of the fit's residuals |r̂(Aᵢ) − rᵢ| over the poses, µrad.
    pub fit_rms_urad: f64,
    /// Leave-one-pose-out RMS prediction error, µrad (`None` with too few poses).
    pub held_out_rms_urad: Option<f64>,
}

/// Both candidate fits of the rotation vectors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RotationDependence {
    pub rigid: DependenceFit,
    pub compliant: Option<DependenceFit>,
    /// Which rotation vectors were modelled (`pooled`: e₁ from the phase, theoretical
    /// frames from the A = 0 frame pooled over all poses).
    pub source: String,
}

fn design(a: &[f64], compliant: bool) -> DMatrix<f64> {
    let cols = if compliant { 3 } else { 1 };
    DMatrix::from_fn(a.len(), cols, |i, k| match k {
        0 => 1.0,
        1 => a[i].sin(),
        _ => a[i].cos(),
    })
}

/// Coefficients (rows: 1, sin, cos; columns: x, y, z).
fn solve(a: &[f64], r: &[Vector3<f64>], compliant: bool) -> DMatrix<f64> {
    let x = design(a, compliant);
    let y = DMatrix::from_fn(r.len(), 3, |i, k| r[i][k]);
    x.svd(true, true)
        .solve(&y, 1e-12)
        .expect("SVD solve with U and V")
}

fn predict(coef: &DMatrix<f64>, a: f64) -> Vector3<f64> {
    let row = design(&[a], coef.nrows() == 3);
    let p = row * coef;
    Vector3::new(p[0], p[1], p[2])
}

fn fit_one(a: &[f64], r: &[Vector3<f64>], compliant: bool, min_poses: usize) -> DependenceFit {
    let coef = solve(a, r, compliant);
    let ss: f64 = a
        .iter()
        .zip(r)
        .map(|(ai, ri)| (predict(&coef, *ai) - ri).norm_squared())
        .sum();
    let held_out = (a.len() >= min_poses).then(|| {
        let mut s = 0.0;
        for i in 0..a.len() {
            let (ai, ri): (Vec<f64>, Vec<Vector3<f64>>) = a
                .iter()
                .zip(r)
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, (x, y))| (*x, *y))
                .unzip();
            let c = solve(&ai, &ri, compliant);
            s += (predict(&c, a[i]) - r[i]).norm_squared();
        }
        (s / a.len() as f64).sqrt()
    });
    let row = |k: usize| [coef[(k, 0)], coef[(k, 1)], coef[(k, 2)]];
    DependenceFit {
        model: if compliant {
            Dependence::Compliant
        } else {
            Dependence::Rigid
        },
        r0_urad: row(0),
        sin_urad: compliant.then(|| row(1)),
        cos_urad: compliant.then(|| row(2)),
        fit_rms_urad: (ss / a.len() as f64).sqrt(),
        held_out_rms_urad: held_out,
    }
}

/// Fits both models to rotation vectors `r_urad` at poses `a_rad`.
pub fn fit_dependence(a_rad: &[f64], r_urad: &[Vector3<f64>]) -> RotationDependence {
    let rigid = fit_one(a_rad, r_urad, false, 3);
    let compliant = (a_rad.len() >= 5).then(|| fit_one(a_rad, r_urad, true, 5));
    RotationDependence {
        rigid,
        compliant,
        source: "pooled".into(),
    }
}
