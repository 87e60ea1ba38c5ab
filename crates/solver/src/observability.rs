//! Identifiability of the error model for a given test plan (kinematics contract,
//! "Identifiability is part of the answer").
//!
//! After the reduction of [`crate::design::fit`], the columns are ordered
//! [mounting rotations | error parameters | extra]; because the leading block of a QR
//! factor is the factor of the leading columns, the rank of the error block after the
//! nuisance parameters are eliminated is
//!
//! rank([rotations | errors]) − rank([rotations]).
//!
//! A parameter is determined by the data iff it is orthogonal to the null space of the
//! column-scaled system (its row of the null-space basis vanishes); a linear functional
//! wᵀx (a value on the grid, a reported squareness) is estimable iff Nᵀ D⁻¹ w = 0. Terms
//! whose parameters share null vectors are confounded: the data determine only their
//! combination.

use crate::design::{ErrorModel, Fit};
use crate::lsq::block_rank;

/// Tolerance on the null-space components of a determined parameter (scaled coordinates).
pub const NULL_TOL: f64 = 1e-6;

/// What the data determine.
#[derive(Debug, Clone)]
pub struct Identifiability {
    /// Rank of the error block after eliminating the mounting rotations.
    pub rank: usize,
    /// Number of error parameters.
    pub parameters: usize,
    /// Per error parameter: determined by the data.
    pub param_determined: Vec<bool>,
    /// Per mounting: rotation determined.
    pub rotation_determined: Vec<bool>,
    /// Groups of error-parameter indices the data cannot separate.
    pub groups: Vec<Vec<usize>>,
    /// Ratio of the largest to the smallest retained singular value (column-scaled).
    pub condition_number: f64,
}

/// Analyses a fitted (or structure-only) session model.
pub fn analyse(fit: &Fit, model: &ErrorModel) -> Identifiability {
    let lay = &fit.layout;
    let n_rot = lay.n_rot();
    let rank_all = block_rank(&fit.reduced, 0..n_rot + lay.n_err);
    let rank_rot = block_rank(&fit.reduced, 0..n_rot);
    let ns = &fit.solution.null_space;
    let nnull = ns.ncols();
    let determined = |j: usize| (0..nnull).all(|c| ns[(j, c)].abs() < NULL_TOL);
    let param_determined: Vec<bool> = lay.err_range().map(determined).collect();
    let rotation_determined: Vec<bool> = (0..n_rot).map(determined).collect();
    // Union-find over undetermined error parameters sharing a null vector.
    let n = model.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], i: usize) -> usize {
        let mut r = i;
        while p[r] != r {
            r = p[r];
        }
        p[i] = r;
        r
    }
    for c in 0..nnull {
        let members: Vec<usize> = (0..n)
            .filter(|&j| ns[(n_rot + j, c)].abs() >= NULL_TOL)
            .collect();
        for w in members.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            parent[a] = b;
        }
    }
    // A term is one unit: its undetermined coefficients belong to one group.
    for a in 0..n {
        for b in a + 1..n {
            if !param_determined[a]
                && !param_determined[b]
                && model.params[a].term_name() == model.params[b].term_name()
            {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                parent[ra] = rb;
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut root_of: Vec<Option<usize>> = vec![None; n];
    for j in 0..n {
        if param_determined[j] {
            continue;
        }
        let r = find(&mut parent, j);
        match root_of[r] {
            Some(g) => groups[g].push(j),
            None => {
                root_of[r] = Some(groups.len());
                groups.push(vec![j]);
            }
        }
    }
    let s = &fit.solution.singular_values;
    let r = fit.solution.rank;
    let condition_number = if r > 0 {
        s[0] / s[r - 1]
    } else {
        f64::INFINITY
    };
    Identifiability {
        rank: rank_all - rank_rot,
        parameters: n,
        param_determined,
        rotation_determined,
        groups,
        condition_number,
    }
}

/// Whether the linear functional wᵀx_err of the error parameters is estimable.
pub fn estimable(fit: &Fit, w_err: &[f64]) -> bool {
    let lay = &fit.layout;
    let ns = &fit.solution.null_space;
    let norms = &fit.solution.column_norms;
    let off = lay.n_rot();
    let scale: f64 = w_err
        .iter()
        .enumerate()
        .map(|(j, w)| (w / norms[off + j]).powi(2))
        .sum::<f64>()
        .sqrt();
    if scale == 0.0 {
        return true;
    }
    (0..ns.ncols()).all(|c| {
        let p: f64 = w_err
            .iter()
            .enumerate()
            .map(|(j, w)| w / norms[off + j] * ns[(off + j, c)])
            .sum();
        (p / scale).abs() < NULL_TOL * 10.0
    })
}

/// Variance of the functional wᵀx_err.
pub fn functional_variance(fit: &Fit, w_err: &[f64]) -> f64 {
    functional_covariance(fit, w_err, w_err).max(0.0)
}

/// Covariance w_aᵀ Σ w_b of two linear functionals of the error parameters (same layout
/// as [`functional_variance`]).
pub fn functional_covariance(fit: &Fit, wa: &[f64], wb: &[f64]) -> f64 {
    let off = fit.layout.n_rot();
    let cov = &fit.solution.cov;
    let mut v = 0.0;
    for (a, x) in wa.iter().enumerate() {
        if *x == 0.0 {
            continue;
        }
        for (b, y) in wb.iter().enumerate() {
            v += x * y * cov[(off + a, off + b)];
        }
    }
    v
}

/// Names of the terms of a parameter group, deduplicated in order.
pub fn group_terms(model: &ErrorModel, group: &[usize]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for &j in group {
        let n = model.params[j].term_name();
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
}
