//! The exact interpolant of a line or circle run's design block, and the exact
//! reduction of such a run at O(n m²) ([`compress_run`]).

use crate::design::{ErrorModel, Layout, MOVING_MM, geometric_row};
use crate::session::Session;

/// How a run's commanded path is parametrised for [`compress_run`].
enum PathParam {
    /// Line along axis index `axis`: s = q[axis], other coordinates fixed.
    Line { axis: usize },
    /// Circle in the plane about (cu, cv) with radius r: s = angle.
    Circle { cu: f64, cv: f64, r: f64 },
}

/// Chebyshev polynomials T_0..T_{m−1} at x.
fn chebyshev(x: f64, m: usize, out: &mut [f64]) {
    if m > 0 {
        out[0] = 1.0;
    }
    if m > 1 {
        out[1] = x;
    }
    for j in 2..m {
        out[j] = 2.0 * x * out[j - 1] - out[j - 2];
    }
}

/// A line or circle run's design block as an exact interpolant.
///
/// Along a line (one axis moving, the others parked) every design row is a polynomial of
/// degree ≤ N + 1 in the moving coordinate (basis of degree N times an Abbe arm linear in
/// position); around a circle it is a trigonometric polynomial of degree ≤ N + 1 in the
/// angle. So the run's block is A = Φ P, with Φ the n × m matrix of basis functions
/// (Chebyshev, or 1, cos jθ, sin jθ) at the samples and P = V⁻¹ A(nodes) obtained by
/// interpolation at m nodes (one P per reading direction), checked at a handful of
/// samples. Used to reduce the run ([`compress_run`]) and to predict its readings
/// ([`residuals`]) at O(m) per sample.
pub(crate) struct RunInterpolant {
    /// Number of basis functions m.
    pub(crate) m: usize,
    /// Trigonometric degree (circles) = polynomial degree − 1 of the lines' basis.
    degree: usize,
    path: PathParam,
    /// Plane axes' indices (u, v).
    iu: usize,
    iv: usize,
    /// Line: centre and half width of the moving coordinate.
    centre: f64,
    half: f64,
    /// P (m × k) per reading direction (u, v).
    pub(crate) pms: [nalgebra::DMatrix<f64>; 2],
}

impl RunInterpolant {
    /// The interpolant of run `r` of plane `p`, or `None` when the run is not a line or
    /// circle path (or is too short to be worth it).
    pub(crate) fn new(
        session: &Session,
        model: &ErrorModel,
        layout: &Layout,
        p: usize,
        r: usize,
    ) -> Option<RunInterpolant> {
        let record = &session.planes[p];
        let run = &record.runs[r];
        let n = run.len();
        let k = layout.n_rot() + layout.n_err;
        if n < 4 * (2 * model.order + 4) {
            return None;
        }
        let (u_ax, v_ax) = record.plane.axes();
        let (iu, iv) = (u_ax.index(), v_ax.index());
        let range = |a: usize| {
            run.pos_mm
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[a]), hi.max(q[a]))
                })
        };
        let moving: Vec<usize> = (0..3)
            .filter(|&a| {
                let (lo, hi) = range(a);
                hi - lo > MOVING_MM
            })
            .collect();
        let path = match moving.as_slice() {
            [a] => PathParam::Line { axis: *a },
            [a, b] if (*a == iu || *a == iv) && (*b == iu || *b == iv) => {
                let uv: Vec<(f64, f64)> = run.pos_mm.iter().map(|q| (q[iu], q[iv])).collect();
                let (cu, cv, r) = crate::session::kasa_circle(&uv)?;
                PathParam::Circle { cu, cv, r }
            }
            _ => return None,
        };
        let degree = model.order + 1;
        let (m, centre, half) = match path {
            PathParam::Line { axis } => {
                let (lo, hi) = range(axis);
                (degree + 1, 0.5 * (lo + hi), 0.5 * (hi - lo))
            }
            PathParam::Circle { .. } => (2 * degree + 1, 0.0, 1.0),
        };
        let mut out = RunInterpolant {
            m,
            degree,
            path,
            iu,
            iv,
            centre,
            half,
            pms: [
                nalgebra::DMatrix::zeros(0, 0),
                nalgebra::DMatrix::zeros(0, 0),
            ],
        };
        let q0 = run.pos_mm[0];
        // Interpolation nodes: Chebyshev points on [−1, 1], or equispaced angles.
        let nodes: Vec<f64> = (0..m)
            .map(|j| {
                if out.is_circle() {
                    2.0 * std::f64::consts::PI * j as f64 / m as f64 - std::f64::consts::PI
                } else {
                    ((2 * j + 1) as f64 * std::f64::consts::PI / (2 * m) as f64).cos()
                }
            })
            .collect();
        let mut vmat = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut phi = vec![0.0; m];
        for (j, &s) in nodes.iter().enumerate() {
            out.basis_at_s(s, &mut phi);
            for c in 0..m {
                vmat[(j, c)] = phi[c];
            }
        }
        let lu = vmat.lu();
        let mut row = vec![0.0; k];
        for comp in 0..2 {
            let mut anodes = nalgebra::DMatrix::<f64>::zeros(m, k);
            for (j, &s) in nodes.iter().enumerate() {
                geometric_row(model, layout, p, record, out.q_of(s, q0), comp, &mut row);
                for c in 0..k {
                    anodes[(j, c)] = row[c];
                }
            }
            let pm = lu.solve(&anodes)?;
            for i in [0, n / 7, n / 3, n / 2, 2 * n / 3, 6 * n / 7, n - 1] {
                let q = run.pos_mm[i];
                let qq = out.q_of(out.s_of(&q), q0);
                if (0..3).any(|a| (qq[a] - q[a]).abs() > 1e-6) {
                    return None;
                }
                geometric_row(model, layout, p, record, q, comp, &mut row);
                out.basis_at_q(&q, &mut phi);
                let scale = row.iter().fold(1e-12, |a: f64, v| a.max(v.abs()));
                for c in 0..k {
                    let rep: f64 = (0..m).map(|j| phi[j] * pm[(j, c)]).sum();
                    if (rep - row[c]).abs() > 1e-9 * scale {
                        return None;
                    }
                }
            }
            out.pms[comp] = pm;
        }
        Some(out)
    }

    fn is_circle(&self) -> bool {
        matches!(self.path, PathParam::Circle { .. })
    }

    /// Path parameter of a position: scaled coordinate in [−1, 1], or angle.
    fn s_of(&self, q: &[f64; 3]) -> f64 {
        match self.path {
            PathParam::Line { axis } => (q[axis] - self.centre) / self.half,
            PathParam::Circle { cu, cv, .. } => (q[self.iv] - cv).atan2(q[self.iu] - cu),
        }
    }

    /// Position on the path at parameter `s` (the parked coordinates of `q0`).
    fn q_of(&self, s: f64, q0: [f64; 3]) -> [f64; 3] {
        let mut q = q0;
        match self.path {
            PathParam::Line { axis } => q[axis] = self.centre + self.half * s,
            PathParam::Circle { cu, cv, r } => {
                q[self.iu] = cu + r * s.cos();
                q[self.iv] = cv + r * s.sin();
            }
        }
        q
    }

    /// Basis at an angle (cos θ, sin θ) by the angle-addition recurrence.
    fn trig(&self, c1: f64, s1: f64, out: &mut [f64]) {
        out[0] = 1.0;
        let (mut c, mut sn) = (1.0, 0.0);
        for j in 1..=self.degree {
            let c_next = c * c1 - sn * s1;
            sn = sn * c1 + c * s1;
            c = c_next;
            out[2 * j - 1] = c;
            out[2 * j] = sn;
        }
    }

    fn basis_at_s(&self, s: f64, out: &mut [f64]) {
        if self.is_circle() {
            self.trig(s.cos(), s.sin(), out);
        } else {
            chebyshev(s, self.m, out);
        }
    }

    pub(crate) fn basis_at_q(&self, q: &[f64; 3], out: &mut [f64]) {
        match self.path {
            PathParam::Circle { cu, cv, r } => {
                self.trig((q[self.iu] - cu) / r, (q[self.iv] - cv) / r, out)
            }
            PathParam::Line { .. } => chebyshev(self.s_of(q), self.m, out),
        }
    }
}

/// Exact reduction of one line or circle run (no extra columns): with the run's block
/// A = Φ P ([`RunInterpolant`]), centring (the zero offsets) removes Φ's constant
/// column, and with the thin QR [Φ_c | b_c] = Q [R₁₁ r₁₂; 0 r₂₂] the run contributes the
/// m rows [R₁₁ P | r₁₂] and [0 | r₂₂] — exactly the same triangular factor as its n
/// rows, at O(n m²) cost instead of O(n k²). `None` (use the dense path) when the run is
/// not such a path.
pub(super) fn compress_run(
    session: &Session,
    model: &ErrorModel,
    layout: &Layout,
    p: usize,
    r: usize,
) -> Option<Vec<(Vec<f64>, f64)>> {
    let interp = RunInterpolant::new(session, model, layout, p, r)?;
    let run = &session.planes[p].runs[r];
    let n = run.len();
    let k = layout.n_rot() + layout.n_err;
    let m = interp.m;
    let mut phi = vec![0.0; m];
    // One thin QR of the centred [Φ (without its constant column) | b_u | b_v]: both
    // directions share Φ, so Q₁ᵀb and the residual of each follow from one factor.
    let mm = m - 1;
    let mut fm = faer::Mat::<f64>::zeros(n, mm + 2);
    let mut mean = vec![0.0; mm + 2];
    for i in 0..n {
        interp.basis_at_q(&run.pos_mm[i], &mut phi);
        for j in 0..mm {
            fm[(i, j)] = phi[j + 1];
            mean[j] += phi[j + 1];
        }
        fm[(i, mm)] = run.du_um[i];
        fm[(i, mm + 1)] = run.dv_um[i];
        mean[mm] += run.du_um[i];
        mean[mm + 1] += run.dv_um[i];
    }
    for (j, mu) in mean.iter().enumerate() {
        let mu = mu / n as f64;
        for v in fm.col_mut(j).iter_mut() {
            *v -= mu;
        }
    }
    let qr = fm.qr();
    crate::upper_state::clear();
    let rr = qr.thin_R();
    let mut out = Vec::new();
    for (comp, pm) in interp.pms.iter().enumerate() {
        for i in 0..mm {
            let mut a = vec![0.0; k];
            for c in 0..k {
                a[c] = (i..mm).map(|j| rr[(i, j)] * pm[(j + 1, c)]).sum();
            }
            out.push((a, rr[(i, mm + comp)]));
        }
        // What of b lies outside span(Φ): one entry for u, two for v.
        let rest = if comp == 0 {
            rr[(mm, mm)].abs()
        } else {
            (rr[(mm, mm + 1)].powi(2) + rr[(mm + 1, mm + 1)].powi(2)).sqrt()
        };
        out.push((vec![0.0; k], rest));
    }
    Some(out)
}
