//! The searches of the thermal drift's time constant T and of the lag τ of a logged
//! temperature's lagged form, on the reduced problem.
//!
//! The thermal columns along direction j are g(t)·q_j·10⁻³ and g(t), with g = 1 − e^(−t/T)
//! (the time form) or g = the smoothed temperature change through a first-order lag of
//! time constant τ ([`Smoother::lagged`](super::temperature::Smoother::lagged)). Within
//! run g, with t_m its middle time, h its half duration and s = (t − t_m)/h ∈ [−1, 1], g
//! is interpolated at K Chebyshev nodes, g ≈ Σ_{k<K} c_k T_k(s). For the time form
//! e^(−t/T) = e^(−t_m/T) e^(−β s), β = h/T, and the error is about 2(β/2)^K/K!, 4·10⁻¹¹
//! for β = 0.1 and K = 6, relative to e^(−t_m/T). The lagged temperature is the response
//! of a first-order lag to a polynomial of the session time (the smoother's), smooth over
//! a run; only its start from equilibrium at the session's first sample adds a transient
//! e^(−(t − t₀)/τ) to the first run, of size the temperature's rate times τ. So every T's
//! or τ's columns are, run by run, fixed combinations of the 6K basis columns
//! ψ_{j,k} = T_k(s)·[q_j·10⁻³, 1] along j, whose moments ([`Moments`]) are formed in one
//! pass over the rows; the profile S(T) or S(τ) of the joint fit then costs only small
//! products per run and trial value (the lag's, besides, one integration of the lag over
//! the runs in steps of at most 0.1 s (`FILL_S`), its input evaluated once). The
//! searches use this profile; the chosen value is evaluated exactly from its own columns.

use super::chebyshev;
use super::design::Design;
use super::moments::{Extra, Moments, RunMoments, live_directions};
use super::reduced::Reduction;
use super::temperature::LagInput;
use crate::axis::Axis;

/// Chebyshev terms per run.
const K: usize = 6;

/// The basis moments of the thermal columns, ready for any time constant.
pub struct ThermalBasis {
    mom: Moments,
    /// Middle time and half duration of each run.
    span: Vec<(f64, f64)>,
    /// With a logged temperature: the input of its lag at the session's first sample
    /// time, then, run by run, the K Chebyshev nodes and the run's span every
    /// [`FILL_S`] at most; and where each run's nodes are among those times.
    lag: Option<std::sync::Arc<(LagInput, Vec<usize>)>>,
}

/// Longest step (s) of the lag's integration within a run for the search: the lag is
/// integrated exactly for an input linear between steps, whose error, h²/8 times the
/// temperature's curvature, is then 10⁻² of that of 1 s steps (the exact columns step
/// from sample to sample).
const FILL_S: f64 = 0.1;

impl ThermalBasis {
    /// One pass over the rows; `extra` are the base columns U of the joint fits.
    pub fn new(d: &Design, red: &Reduction, extra: &Extra) -> ThermalBasis {
        let span: Vec<(f64, f64)> = d
            .runs
            .iter()
            .map(|r| {
                let (a, b) = (d.fields.t_s[r.start], d.fields.t_s[r.end - 1]);
                (0.5 * (a + b), (0.5 * (b - a)).max(1e-9))
            })
            .collect();
        // A row read along axis j has only j's 2K columns nonzero (ψ_{j,k} with q_j and
        // without): one pass per reading axis over its rows with those columns, placed
        // into the 6K columns' moments ([`place`]).
        let per_axis = Axis::ALL.map(|a| {
            Moments::new_on(
                red,
                2 * K,
                extra,
                |row| d.row_axis(row) == a,
                |row, out| fill(d, &span, a, row, out),
            )
        });
        let mom = place(&per_axis);
        let lag = d.temperature.as_ref().map(|sm| {
            let first = d.fields.t_s.iter().copied().fold(f64::INFINITY, f64::min);
            let mut times = vec![first];
            let mut at = Vec::with_capacity(span.len());
            for &(tm, h) in &span {
                at.push(times.len());
                times.extend(chebyshev::node_cosines::<K>().map(|c| tm + h * c));
                let fill = (2.0 * h / FILL_S).ceil().max(1.0) as usize;
                times.extend((0..=fill).map(|j| tm - h + 2.0 * h * j as f64 / fill as f64));
            }
            std::sync::Arc::new((sm.lag_input(&times), at))
        });
        ThermalBasis { mom, span, lag }
    }

    /// How many of the six columns vary within some run (are not absorbed by the run
    /// offsets): those whose K basis columns do not all vanish there, the columns a joint
    /// fit at any time constant keeps.
    pub fn varying(&self) -> usize {
        (0..6)
            .filter(|&c| self.mom.varies[c * K..(c + 1) * K].iter().any(|&v| v))
            .count()
    }

    /// The basis formed with a base of `u_prev` columns, carried to the base `extra`
    /// after the model gained columns ([`Moments::carried`]): only the products with the
    /// columns added since are formed, one pass per reading axis over its rows with its
    /// 2K columns, placed as [`place`] places the whole moments; the same sums as
    /// [`ThermalBasis::new`] on that base.
    pub fn carried(
        &self,
        d: &Design,
        red: &Reduction,
        extra: &Extra,
        u_prev: usize,
    ) -> ThermalBasis {
        let mom = self.mom.carried(extra, u_prev, |added| {
            let per_axis = Axis::ALL.map(|a| {
                Moments::cross(
                    red,
                    2 * K,
                    added,
                    live_directions(|row| d.row_axis(row) == a),
                    |row, out| fill(d, &self.span, a, row, out),
                )
            });
            let n = added.cols.len();
            (0..red.runs.len())
                .map(|g| {
                    let mut xu = vec![0.0; 6 * K * n];
                    for (j, part) in per_axis.iter().enumerate() {
                        for l in 0..2 * K {
                            let c = col(j, l);
                            xu[c * n..(c + 1) * n].copy_from_slice(&part[g][l * n..(l + 1) * n]);
                        }
                    }
                    xu
                })
                .collect()
        });
        ThermalBasis {
            mom,
            span: self.span.clone(),
            lag: self.lag.clone(),
        }
    }

    /// The moments of the six thermal columns (scale X, Y, Z, offset X, Y, Z) of the time
    /// form at time constant `t`.
    pub fn at(&self, t: f64) -> Moments {
        self.combine(|_, (tm, h)| coefficients(tm, h, t))
    }

    /// The moments of the six columns of the lagged form (the smoothed temperature change
    /// through a first-order lag of time constant `tau`,
    /// [`Smoother::lagged`](super::temperature::Smoother::lagged)), its
    /// interpolant through the lag at every run's nodes; `None` without a logged
    /// temperature.
    pub fn lagged(&self, tau: f64) -> Option<Moments> {
        let (input, at) = self.lag.as_deref()?;
        let y = input.lagged(tau);
        Some(self.combine(|g, _| chebyshev::coefficients(std::array::from_fn(|i| y[at[g] + i]))))
    }

    /// The moments of the six thermal columns with g on run g given by its Chebyshev
    /// coefficients `coef(g, (t_m, h))`: column c of the six is Σ_k g_k·ψ_{cK+k}.
    fn combine(&self, coef: impl Fn(usize, (f64, f64)) -> [f64; K]) -> Moments {
        self.mom.combine(6, |run| {
            let g = coef(run, self.span[run]);
            (0..6)
                .map(|c| (0..K).map(|k| (c * K + k, g[k])).collect())
                .collect()
        })
    }
}

/// The moments of the 6K basis columns (scale X, Y, Z, then offset X, Y, Z; K each) from
/// those of each reading axis j's 2K columns on its own rows (`per_axis[j]`: scale j,
/// offset j): the same values where a pass over all rows and columns puts them (no row
/// has two axes' columns nonzero, so the blocks across axes are 0, and so are a column's
/// sums on the other axes' rows).
fn place(per_axis: &[Moments; 3]) -> Moments {
    let m = 6 * K;
    let u = per_axis[0].u;
    let runs = (0..per_axis[0].runs.len())
        .map(|g| {
            let r = per_axis[0].runs[g].z.len() / (2 * K);
            let mut rm = RunMoments {
                z: vec![0.0; m * r],
                xx: vec![0.0; m * m],
                xu: vec![0.0; m * u],
            };
            for (j, part) in per_axis.iter().enumerate() {
                let p = &part.runs[g];
                for l in 0..2 * K {
                    let c = col(j, l);
                    rm.z[c * r..(c + 1) * r].copy_from_slice(&p.z[l * r..(l + 1) * r]);
                    rm.xu[c * u..(c + 1) * u].copy_from_slice(&p.xu[l * u..(l + 1) * u]);
                    for l2 in 0..2 * K {
                        rm.xx[c * m + col(j, l2)] = p.xx[l * 2 * K + l2];
                    }
                }
            }
            rm
        })
        .collect();
    let (mut peaks, mut varies) = (vec![0.0; m], vec![false; m]);
    for (j, part) in per_axis.iter().enumerate() {
        for l in 0..2 * K {
            (peaks[col(j, l)], varies[col(j, l)]) = (part.peaks[l], part.varies[l]);
        }
    }
    Moments {
        m,
        u,
        runs,
        peaks,
        local: vec![false; m],
        varies,
    }
}

/// The column of the 6K (scale X, Y, Z, then offset X, Y, Z) of reading axis j's column
/// l of its 2K (scale, then offset).
fn col(j: usize, l: usize) -> usize {
    if l < K {
        j * K + l
    } else {
        (3 + j) * K + l - K
    }
}

/// The 2K basis columns of reading axis `a` at `row` (read along `a`): T_k(s)·q_a·10⁻³,
/// then T_k(s), s the row's time within its run (middle and half duration `span`).
fn fill(d: &Design, span: &[(f64, f64)], a: Axis, row: usize, out: &mut [f64]) {
    let (s, f, j) = (row / 2, &d.fields, a.index());
    let (tm, h) = span[f.run(s)];
    let tk = chebyshev::values::<K>((f.t_s[s] - tm) / h);
    for k in 0..K {
        out[k] = tk[k] * f.q_mm[j][s] * 1e-3;
        out[K + k] = tk[k];
    }
}

/// Chebyshev coefficients on a run (middle `tm`, half duration `h`) of
/// g(t) = 1 − e^(−t/T) in τ = (t − tm)/h.
fn coefficients(tm: f64, h: f64, t: f64) -> [f64; K] {
    let beta = h / t;
    let scale = (-tm / t).exp();
    let c = chebyshev::coefficients(chebyshev::node_cosines::<K>().map(|x| (-beta * x).exp()));
    let mut g = c.map(|ck| -scale * ck);
    g[0] += 1.0;
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnosis::design;
    use crate::diagnosis::moments::{Base, Sets, joint_fit};
    use crate::simulate::seed_session;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use std::f64::consts::PI;

    /// The lagged form's profile S(τ) from the basis moments equals the one from the
    /// exact lagged columns (the lag at every sample, their moments formed over the rows)
    /// within 10⁻⁴ of the noise variance (10⁻² at a lag of 1 s, a transient in the first
    /// run), from 1 s to 400 s, on a session of 1 650 s whose Z readings grow 4 µm/K with
    /// the logged temperature (a sine of 2 K amplitude and 1 000 s period, sensor noise
    /// 5 mK).
    #[test]
    fn lagged_profile_matches_the_exact_columns() {
        let mut s = seed_session(3);
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let sensor = Normal::new(0.0, 0.005).unwrap();
        for p in &mut s.planes {
            let (u, v) = p.plane.axes();
            for r in &mut p.runs {
                let temp: Vec<f64> = r
                    .t_s
                    .iter()
                    .map(|&t| 2.0 * (2.0 * PI * t / 1000.0).sin())
                    .collect();
                for (i, dt) in temp.iter().enumerate() {
                    if u == Axis::Z {
                        r.du_um[i] += 4.0 * dt;
                    }
                    if v == Axis::Z {
                        r.dv_um[i] += 4.0 * dt;
                    }
                }
                r.temp_c = Some(
                    temp.iter()
                        .map(|dt| 20.0 + dt + sensor.sample(&mut rng))
                        .collect(),
                );
            }
        }
        let d = design::build(&s, &Default::default(), 3).unwrap();
        let red = Reduction::new(&s, &d);
        let sets = Sets::new(&d, &red, 3);
        let base = Base::new(&red, &sets, Moments::of_columns(&red, &[&d.y]));
        let sm = d.temperature.as_ref().unwrap();
        let basis = ThermalBasis::new(&d, &red, &Extra::plain(&[&d.y]));
        for tau in [1.0, 5.0, 30.0, 120.0, 400.0] {
            let lag = sm.lagged(&d.fields.t_s, tau);
            let exact = Moments::new(&red, 6, &Extra::plain(&[&d.y]), |row, out| {
                let (s, j) = (row / 2, d.row_axis(row).index());
                out.fill(0.0);
                out[j] = lag[s] * d.fields.q_mm[j][s] * 1e-3;
                out[3 + j] = lag[s];
            });
            let ssr = |m: &Moments| joint_fit(&red, &sets, Some(m), &base, false).all.ssr;
            let (want, got) = (ssr(&exact), ssr(&basis.lagged(tau).unwrap()));
            // S per row is the noise variance σ² (0.15 µm)²: the profile's error is below
            // 10⁻⁴ of it, against the 4σ² of τ's 2σ interval; 10⁻² at 1 s, where the
            // first run's transient is not a short Chebyshev series.
            let sigma2 = want / d.rows() as f64;
            let tol = if tau < 2.0 { 1e-2 } else { 1e-4 };
            assert!(
                (got - want).abs() <= tol * sigma2,
                "τ = {tau}: {got} vs {want}, σ² {sigma2}"
            );
        }
    }

    /// The basis carried to a base that gained two columns (one nonzero on the X
    /// readings only, one everywhere) holds the same moments, bit for bit, as the basis
    /// formed on that base in one pass; so do the moments of the time form combined
    /// from it.
    #[test]
    fn carried_basis_is_the_basis_formed_on_the_new_base() {
        let s = seed_session(5);
        let d = design::build(&s, &Default::default(), 3).unwrap();
        let red = Reduction::new(&s, &d);
        let n = d.y.len();
        let on_x: Vec<f64> = (0..n)
            .map(|row| {
                if d.row_axis(row) == Axis::X {
                    (0.37 * row as f64).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let everywhere: Vec<f64> = (0..n).map(|row| (0.011 * row as f64).cos()).collect();
        let before = ThermalBasis::new(&d, &red, &Extra::plain(&[&d.y]));
        let cols = [on_x.as_slice(), everywhere.as_slice(), d.y.as_slice()];
        let support = Extra::support_of(&red, &cols);
        let extra = Extra {
            cols: cols.to_vec(),
            support: support.as_deref(),
        };
        let carried = before.carried(&d, &red, &extra, 1);
        let fresh = ThermalBasis::new(&d, &red, &extra);
        let same = crate::diagnosis::moments::assert_same_bits;
        same(&carried.mom, &fresh.mom);
        same(&carried.at(300.0), &fresh.at(300.0));
        // Not the basis it was carried from: the new columns' products are there.
        assert!(
            carried
                .mom
                .runs
                .iter()
                .any(|r| r.xu.iter().any(|&v| v != 0.0))
        );
        assert_eq!(before.mom.u, 1);
    }

    /// The interpolant reproduces g(t) = 1 − e^(−t/T) on a run (β = 0.1) within the
    /// truncation bound 2(β/2)^K/K!·e^β·e^(−t_m/T) ≈ 9·10⁻¹².
    #[test]
    fn chebyshev_reproduces_the_growth() {
        let (tm, h, t) = (500.0, 30.0, 300.0);
        let g = coefficients(tm, h, t);
        for i in 0..=20 {
            let tau = -1.0 + 0.1 * i as f64;
            let (mut p0, mut p1) = (1.0, tau);
            let mut v = g[0] + g[1] * tau;
            for gk in &g[2..] {
                let p2 = 2.0 * tau * p1 - p0;
                v += gk * p2;
                (p0, p1) = (p1, p2);
            }
            let want = 1.0 - (-(tm + h * tau) / t).exp();
            let beta: f64 = h / t;
            let fact: f64 = (1..=K).map(|k| k as f64).product();
            let bound = 2.0 * (beta / 2.0).powi(K as i32) / fact * beta.exp() * (-tm / t).exp();
            assert!(
                (v - want).abs() < bound,
                "{tau}: {v} vs {want}, bound {bound}"
            );
        }
    }
}
