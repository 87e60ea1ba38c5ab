//! A trial's parameters in physical units with their standard uncertainties: the
//! nonlinear parameter's uncertainty carried into the others, and the profile
//! parameters' pointwise σ.

use crate::axis::Axis;
use crate::diagnosis::catalogue;
use crate::diagnosis::design::Design;
use crate::diagnosis::lost_motion::Profile;
use crate::diagnosis::session::trial::Trial;
use crate::diagnosis::session::trial::profile_likelihood::TimeConstantInterval;
use crate::diagnosis::temperature;
use std::collections::BTreeMap;

/// Carries the uncertainty `sd` of a nonlinear parameter into the other reported
/// parameters of trial `t` (σ² + (dβ/dθ·σ_θ)²): its coefficients moved by ±σ_θ along
/// their slope `slope` (so a parameter made of several coefficients, an amplitude of its
/// sine and cosine, moves as reported), half the difference of the reported figures added
/// in quadrature to each σ in `params`; `skip` is the nonlinear parameter's own name.
pub(crate) fn carry(
    params: &mut BTreeMap<String, f64>,
    (t, sigma, d): (&Trial, f64, &Design),
    slope: &[f64],
    sd: f64,
    skip: &str,
) {
    let moved = |sign: f64| {
        let mut m = t.clone();
        for (c, b) in m.coef.iter_mut().zip(slope) {
            *c += sign * b * sd;
        }
        report_parameters(&m, sigma, d)
    };
    let (up, down) = (moved(1.0), moved(-1.0));
    for (n, v) in &up {
        if n.starts_with("std_") || n.starts_with("phase") || n == skip {
            continue;
        }
        let shift = 0.5 * (v - down.get(n).copied().unwrap_or(*v));
        if let Some(sd) = params.get_mut(&format!("std_{n}")) {
            *sd = sd.hypot(shift);
        }
    }
}

/// Carries a thermal drift's time constant's interval into the other reported
/// parameters of trial `t`: each refigured from the coefficients at T₋ and at T₊
/// ([`Ctx::time_constant_interval`], the 2σ bounds), half the larger change from the
/// reported figure (one σ's worth of the wider side) added in quadrature to its σ.
pub(crate) fn carry_interval(
    params: &mut BTreeMap<String, f64>,
    (t, sigma, d): (&Trial, f64, &Design),
    iv: &TimeConstantInterval,
    skip: &str,
) {
    let at = |coef: &[f64]| {
        let mut m = t.clone();
        m.coef = coef.to_vec();
        report_parameters(&m, sigma, d)
    };
    let (low, high) = (at(&iv.coef_low), at(&iv.coef_high));
    let here = report_parameters(t, sigma, d);
    for (n, v) in &here {
        if n.starts_with("std_") || n.starts_with("phase") || n == skip {
            continue;
        }
        let side = |m: &BTreeMap<String, f64>| (m.get(n).copied().unwrap_or(*v) - v).abs();
        let shift = 0.5 * side(&low).max(side(&high));
        if let Some(sd) = params.get_mut(&format!("std_{n}")) {
            *sd = sd.hypot(shift);
        }
    }
}

/// A thermal drift's growth over the recorded span: each offset and scale times
/// g(t_end) = 1 − e^(−t_end/T), t_end the last sample's time, reported as
/// `span_{name}` with its σ (conditional on T, times g) and half the larger change of
/// the product at T's bounds ([`Ctx::time_constant_interval`]) added in quadrature. What
/// the recording saw, determined where T and the final growth are not (a session not
/// much longer than T: the growth nearly a straight line in time); nothing evaluated
/// beyond the last sample.
pub(crate) fn span_growth(
    params: &mut BTreeMap<String, f64>,
    (t, sigma): (&Trial, f64),
    iv: &TimeConstantInterval,
    t_end: f64,
) {
    let Some((_, th)) = t.theta else {
        return;
    };
    let g = |tc: f64| -(-t_end / tc).exp_m1();
    for (i, name) in t.names.iter().enumerate() {
        if catalogue::is_nuisance(name) {
            continue;
        }
        let v = t.coef[i] * g(th);
        let low = iv.coef_low[i] * g(iv.fitted_at[0]);
        let high = iv.coef_high[i] * g(iv.fitted_at[1]);
        let shift = 0.5 * (low - v).abs().max((high - v).abs());
        params.insert(format!("span_{name}"), v);
        params.insert(
            format!("std_span_{name}"),
            (t.coef_sd[i] * sigma * g(th)).hypot(shift),
        );
    }
}

/// Physical parameters of an accepted trial (with `std_*` uncertainties), scaled by the
/// residual standard deviation `sigma` of the joint fit.
pub(crate) fn report_parameters(t: &Trial, sigma: f64, d: &Design) -> BTreeMap<String, f64> {
    let mut p = BTreeMap::new();
    let sd = |i: usize| t.coef_sd[i] * sigma;
    if let Some((name, v)) = t.theta {
        if catalogue::is_own_value(name) {
            // A play's take-up travel is its lost motion, a lag's second order the lag:
            // reported as such.
        } else if name == "period_mm" {
            p.insert("period_mm".into(), 1.0 / v);
        } else {
            p.insert(name.into(), v);
        }
    }
    let idx = |n: &str| t.names.iter().position(|x| x == n);
    if let (Some(i), Some(j)) = (idx("sin"), idx("cos")) {
        let (a, b) = (t.coef[i], t.coef[j]);
        p.insert("amplitude_um".into(), a.hypot(b));
        p.insert("std_amplitude_um".into(), sd(i).max(sd(j)));
        p.insert("phase_rad".into(), b.atan2(a));
        return p;
    }
    if t.cand.effect == "model_order" {
        // Size of the extra (higher-order) function as seen in the data: RMS of its fit.
        let n = d.rows() as f64;
        let c = nalgebra::DVector::from_column_slice(&t.coef);
        let rms = ((c.transpose() * &t.gram * &c)[(0, 0)].max(0.0) / n).sqrt();
        p.insert("rms_um".into(), rms);
        p.insert("extra_order".into(), 10.0);
        return p;
    }
    let smoother = t
        .cand
        .effect
        .starts_with("thermal_temperature")
        .then(|| smoother_variance(t, d))
        .flatten();
    for (i, name) in t.names.iter().enumerate() {
        if catalogue::is_nuisance(name) {
            continue;
        }
        p.insert(name.clone(), t.coef[i]);
        let sd = match &smoother {
            Some(v) => (sd(i).powi(2) + v[i]).sqrt(),
            None => sd(i),
        };
        p.insert(format!("std_{name}"), sd);
    }
    p
}

/// Number of points along the measured travel at which a session's position-dependent
/// lost motion is reported (evenly spaced, ends included).
const PROFILE_POINTS: usize = 5;

/// The parameters of a position-dependent lost motion of axis `a` (`lost_motion_profile`,
/// the effects table's): b(q) = Σ_k b_k·P_k(s) at [`PROFILE_POINTS`] points of the
/// measured travel, its mean and its variation along the travel, each with its σ. The b_k
/// are the trial's (their covariance: their σ with the correlation of their Gram
/// matrix), b₀ ± σ₀ the `constant` lost motion of the axis's `backlash` in the model when
/// the trial is its varying part alone (taken independent of the b_k).
pub(crate) fn profile_parameters(
    t: &Trial,
    sigma: f64,
    d: &Design,
    a: Axis,
    constant: Option<(f64, f64)>,
) -> BTreeMap<String, f64> {
    let mut p = BTreeMap::new();
    let Some((prof, coef, cov)) = profile_of(t, sigma, d, a, constant) else {
        return p;
    };
    let points: Vec<f64> = (0..PROFILE_POINTS)
        .map(|i| prof.lo + (prof.hi - prof.lo) * i as f64 / (PROFILE_POINTS - 1) as f64)
        .collect();
    let report = |prof: &Profile, coef: &[f64], cov: &nalgebra::DMatrix<f64>| {
        let mut v: Vec<(f64, f64)> = prof.at(coef, cov, &points);
        v.push(prof.mean(coef, cov, &points));
        v.push(prof.variation(coef, cov, &points));
        v
    };
    let mut at = report(&prof, &coef, &cov);
    // The orders the data did not choose are nuisance: each figure's variance takes the
    // largest squared difference from the figure of the next two orders (the richer
    // order's own extra variance where the chosen one describes the lost motion, the
    // chosen one's truncation where it does not: a coefficient just below the BIC's
    // threshold left out of a profile of order 7 biased its ends by 1.5 σ).
    let richer: Vec<Vec<(f64, f64)>> = t
        .forms
        .iter()
        .filter_map(|r| profile_of(r, sigma, d, a, constant))
        .map(|(p, c, v)| report(&p, &c, &v))
        .collect();
    for (i, (x, sx)) in at.iter_mut().enumerate() {
        let wide = richer
            .iter()
            .map(|r| (r[i].0 - *x).powi(2))
            .fold(0.0, f64::max);
        *sx = sx.hypot(wide.sqrt());
    }
    let (v, sv) = at.pop().unwrap_or_default();
    let (mean, sm) = at.pop().unwrap_or_default();
    for (n, ((b, sb), q)) in at.iter().zip(&points).enumerate() {
        p.insert(format!("lost_motion_um_{}", n + 1), *b);
        p.insert(format!("std_lost_motion_um_{}", n + 1), *sb);
        p.insert(format!("target_mm_{}", n + 1), *q);
    }
    p.insert("mean_lost_motion_um".into(), mean);
    p.insert("std_mean_lost_motion_um".into(), sm);
    p.insert("variation_um".into(), v);
    p.insert("std_variation_um".into(), sv);
    p.insert("order".into(), prof.order as f64);
    p
}

/// The profile of a lost-motion trial `t` with its coefficients and their covariance
/// ([`profile_parameters`]).
fn profile_of(
    t: &Trial,
    sigma: f64,
    d: &Design,
    a: Axis,
    constant: Option<(f64, f64)>,
) -> Option<(Profile, Vec<f64>, nalgebra::DMatrix<f64>)> {
    let prof = catalogue::profile(d, a, t.cand.order)?;
    let k = prof.order + 1;
    let mut coef = Vec::with_capacity(k);
    let mut cov = nalgebra::DMatrix::zeros(k, k);
    let off = usize::from(constant.is_some());
    if let Some((b0, sb0)) = constant {
        coef.push(b0);
        cov[(0, 0)] = sb0 * sb0;
    }
    let m = t.coef.len().min(k - off);
    coef.extend(&t.coef[..m]);
    coef.resize(k, 0.0);
    let ginv = t.gram.clone().pseudo_inverse(1e-12).ok();
    for i in 0..m {
        for j in 0..m {
            let corr = match &ginv {
                Some(g) if g[(i, i)] > 0.0 && g[(j, j)] > 0.0 => {
                    g[(i, j)] / (g[(i, i)] * g[(j, j)]).sqrt()
                }
                _ => f64::from(u8::from(i == j)),
            };
            cov[(i + off, j + off)] = corr * t.coef_sd[i] * t.coef_sd[j] * sigma * sigma;
        }
    }
    Some((prof, coef, cov))
}

/// The variance the smoother of the logged temperature adds to each coefficient of a
/// temperature-driven form ([`temperature::Smoother::coefficient_cov`]); infinite where
/// the smoother does not follow the temperature (the coefficients are then
/// undetermined), none without a smoother. The lagged form's columns follow the lagged
/// smoothed temperature, whose error is the smoother's error lagged; the smoother's
/// error is a polynomial of the session time, slow against the lags the data can tell
/// from none, and is taken unlagged.
fn smoother_variance(t: &Trial, d: &Design) -> Option<Vec<f64>> {
    let sm = d.temperature.as_ref()?;
    let kc = t.names.len();
    if !sm.follows {
        return Some(vec![f64::INFINITY; kc]);
    }
    // The columns by name: scale_ppm_per_k_{j} weighs q_j/1000, offset_um_per_k_{j} 1;
    // the `_k2_` ones the same times ΔT̂ once more.
    let col = |name: &str| -> Option<(bool, bool, Axis)> {
        let (scale, quad, a) = [
            ("scale_ppm_per_k_", true, false),
            ("offset_um_per_k_", false, false),
            ("scale_ppm_per_k2_", true, true),
            ("offset_um_per_k2_", false, true),
        ]
        .into_iter()
        .find_map(|(p, scale, quad)| Some((scale, quad, name.strip_prefix(p)?)))?;
        Some((scale, quad, Axis::parse(a)?))
    };
    let cols: Vec<(bool, bool, Axis)> = t.names.iter().map(|n| col(n)).collect::<Option<_>>()?;
    let temp: Vec<f64> = match (t.cand.effect, t.theta) {
        ("thermal_temperature_lag", Some((_, tau))) => d.lagged_temperature(tau)?,
        _ => d.fields.temp_k.clone()?,
    };
    let groups = d.runs.iter().flat_map(|run| {
        let (u, v) = d.plane_axes[run.plane_idx];
        let (cols, temp) = (&cols, &temp);
        [u, v].into_iter().map(move |read| {
            let mut z = Vec::with_capacity((run.end - run.start) * kc);
            let mut growth = Vec::with_capacity(run.end - run.start);
            for s in run.start..run.end {
                let dt = temp[s];
                let mut g = 0.0;
                for (&(scale, quad, a), b) in cols.iter().zip(&t.coef) {
                    let w = match (a == read, scale) {
                        (false, _) => 0.0,
                        (true, true) => d.fields.q_mm[a.index()][s] * 1e-3,
                        (true, false) => 1.0,
                    };
                    // Column ΔT̂·w (derivative w) or ΔT̂²·w (derivative 2ΔT̂·w).
                    let (zv, dz) = if quad {
                        (dt * dt * w, 2.0 * dt * w)
                    } else {
                        (dt * w, w)
                    };
                    z.push(zv);
                    g += b * dz;
                }
                growth.push(g);
            }
            temperature::Group {
                t_s: d.fields.t_s[run.start..run.end].to_vec(),
                z,
                growth,
            }
        })
    });
    let cov = sm.coefficient_cov(groups, &t.gram)?;
    Some((0..kc).map(|i| cov[(i, i)]).collect())
}
