//! One-dimensional searches for the nonlinear parameters of candidate effects (periods,
//! time constants, decay lengths).

/// The state of a golden-section search after its last step: the final bracket [a, b]
/// and its two interior points with their values.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GoldenBracket {
    pub a: f64,
    pub b: f64,
    pub c: (f64, f64),
    pub d: (f64, f64),
}

impl GoldenBracket {
    /// The better of the two interior points (x, f(x)).
    pub fn best(&self) -> (f64, f64) {
        if self.c.1 < self.d.1 { self.c } else { self.d }
    }

    /// Centre of the final bracket.
    pub fn centre(&self) -> f64 {
        0.5 * (self.a + self.b)
    }
}

/// Golden-section minimisation of a unimodal `f` on [a, b], `iters` steps: each step keeps
/// the sub-bracket around the smaller of f(c), f(d), with c = b − g(b − a),
/// d = a + g(b − a), g = (√5 − 1)/2, and re-uses one interior value.
pub(crate) fn golden_section(
    mut a: f64,
    mut b: f64,
    iters: usize,
    mut f: impl FnMut(f64) -> f64,
) -> GoldenBracket {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut c = b - g * (b - a);
    let mut d = a + g * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iters {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(d);
        }
    }
    GoldenBracket {
        a,
        b,
        c: (c, fc),
        d: (d, fd),
    }
}

/// Bayesian information criterion of a Gaussian least-squares fit:
/// BIC = n ln(SSE/n) + k ln n (Schwarz 1978).
pub(crate) fn bic(sse: f64, n: usize, k: f64) -> f64 {
    let nf = n as f64;
    nf * (sse.max(1e-300) / nf).ln() + k * nf.ln()
}

/// ΔBIC = BIC₁ − BIC₀ of a model leaving `sse` with `k` parameters against the current
/// one (`cur_sse`, `cur_k`), both over `n` rows.
pub(crate) fn delta_bic(sse: f64, k: f64, cur_sse: f64, cur_k: f64, n: usize) -> f64 {
    bic(sse, n, k) - bic(cur_sse, n, cur_k)
}

/// The engine's gate on ΔBIC: a candidate may qualify only when ΔBIC ≤ −`threshold`
/// (the engine also asks for a held-out gain).
pub(crate) fn passes_bic_gate(dbic: f64, threshold: f64) -> bool {
    dbic <= -threshold
}

/// Golden-section minimisation of `f` on `[a, b]` (unimodal assumed), `iters` steps;
/// returns the best point found and its value.
pub(crate) fn golden_min(a: f64, b: f64, iters: usize, f: impl FnMut(f64) -> f64) -> (f64, f64) {
    golden_section(a, b, iters, f).best()
}

/// 1-D search: best point of `grid` by `f`, then golden-section refinement between its
/// neighbours. Returns (argmin, min).
pub(crate) fn grid_then_golden(
    grid: &[f64],
    iters: usize,
    mut f: impl FnMut(f64) -> f64,
) -> (f64, f64) {
    let vals: Vec<f64> = grid.iter().map(|&x| f(x)).collect();
    let (ib, &vb) = vals
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .expect("non-empty grid");
    let lo = grid[ib.saturating_sub(1)];
    let hi = grid[(ib + 1).min(grid.len() - 1)];
    if iters == 0 || hi <= lo {
        return (grid[ib], vb);
    }
    let (x, v) = golden_min(lo, hi, iters, &mut f);
    if v < vb { (x, v) } else { (grid[ib], vb) }
}
