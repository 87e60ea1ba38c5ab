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
