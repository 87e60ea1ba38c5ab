//! Likelihood-ratio intervals of a profiled sum of squares: its bounds searched outward
//! from the estimate, located on an approximate profile and confirmed by exact passes.

/// How far in ln T [`Ctx::time_constant_interval`] searches either side of T̂.
pub(super) const LN_REACH: f64 = 3.2;

/// A thermal drift's time constant's 2σ likelihood-ratio interval [T₋, T₊] and the
/// trial's coefficients refitted at each bound ([`Ctx::time_constant_interval`]).
pub(crate) struct TimeConstantInterval {
    pub low: f64,
    pub high: f64,
    /// The T at which the coefficients were refitted: the bounds, within the reach.
    pub fitted_at: [f64; 2],
    pub coef_low: Vec<f64>,
    pub coef_high: Vec<f64>,
}

/// One side of a profile interval: the last offset x (of sign `dir`) from 0 with
/// `within(x)` (0 itself within), searched in steps that double from `first` up to
/// `reach` (the last step cut to it), the crossing then halved six times, i.e. found
/// to 1/64 of its bracket; `true` when still within at the reach (the interval open on
/// that side). Every likelihood-ratio interval of the session's parameters is this
/// search: a thermal drift's time constant (in ln T), a step's width (in ln w) and a
/// ramp's time.
pub(super) fn profile_bound(
    within: impl Fn(f64) -> bool,
    dir: f64,
    first: f64,
    reach: f64,
) -> (f64, bool) {
    let (a, b) = bracket(&within, dir, first, reach);
    (dir * a, b.is_none())
}

/// [`profile_bound`]'s last bracket on one side: the last offset found within and the
/// first found outside (both ≥ 0, along `dir`); `None` outside when still within at the
/// reach.
fn bracket(within: &dyn Fn(f64) -> bool, dir: f64, first: f64, reach: f64) -> (f64, Option<f64>) {
    let (mut inside, mut step) = (0.0, first.min(reach));
    let outside = loop {
        if !within(dir * step) {
            break step;
        }
        inside = step;
        if step >= reach {
            return (reach, None);
        }
        step = (2.0 * step).min(reach);
    };
    let (mut a, mut b) = (inside, outside);
    for _ in 0..6 {
        let m = 0.5 * (a + b);
        if within(dir * m) {
            a = m;
        } else {
            b = m;
        }
    }
    (a, Some(b))
}

/// [`profile_bound`] of `within` (exact, one pass over the rows a call) searched on a
/// cheap profile `near` of the same quantity, its last bracket confirmed by `within`
/// ([`confirmed`]).
pub(super) fn profile_bound_confirmed(
    near: impl Fn(f64) -> bool,
    within: impl Fn(f64) -> bool,
    dir: f64,
    first: f64,
    reach: f64,
) -> (f64, bool) {
    let search = |w: &dyn Fn(f64) -> bool| {
        let (a, b) = bracket(w, dir, first, reach);
        (
            (dir * a, b.is_none()),
            (a != 0.0).then_some(dir * a),
            b.map(|b| dir * b),
        )
    };
    confirmed(search, &near, &within)
}

/// The result of an outward search on the exact predicate `within` (one pass over the
/// rows a call), made on a cheap one `near` of the same quantity and confirmed by
/// `within` at the two places that decide it: `search(p)` returns its result on the
/// predicate p, the last place p held (none: only its start, which is not asked) and the
/// first where it failed (none: the search reached its end within). Within at the one and
/// not at the other: on a profile that crosses its threshold once, every place the
/// search visits lies at or before the first (within) or at or beyond the second (not
/// within), so the search on `within` would make the same decisions, the same result,
/// for at most two exact calls. Otherwise (the cheap profile off near the threshold) the
/// search is made again on `within`.
pub(super) fn confirmed<R>(
    search: impl Fn(&dyn Fn(f64) -> bool) -> (R, Option<f64>, Option<f64>),
    near: &dyn Fn(f64) -> bool,
    within: &dyn Fn(f64) -> bool,
) -> R {
    let (r, inside, outside) = search(near);
    if inside.is_none_or(within) && outside.is_none_or(|x| !within(x)) {
        r
    } else {
        search(within).0
    }
}

#[cfg(test)]
mod tests {
    use super::{LN_REACH, profile_bound, profile_bound_confirmed};
    use std::cell::Cell;

    /// The bounds of a known profile: within where (x − 0.3)² ≤ 0.9, i.e.
    /// 0.3 ± √0.9, found from inside to within one 64th of the bracket ([0.8, 1.6] on the
    /// upper side, [−0.8, −0.4] on the lower); a side that never crosses is open at the
    /// reach.
    #[test]
    fn profile_bound_finds_the_crossings_of_a_known_profile() {
        let r = 0.9f64.sqrt();
        let within = |x: f64| (x - 0.3f64).powi(2) <= 0.9;
        let (hi, open) = profile_bound(within, 1.0, 0.05, LN_REACH);
        assert!(!open && hi <= 0.3 + r && hi > 0.3 + r - 0.8 / 64.0, "{hi}");
        let (lo, open) = profile_bound(within, -1.0, 0.05, LN_REACH);
        assert!(!open && lo >= 0.3 - r && lo < 0.3 - r + 0.4 / 64.0, "{lo}");
        let flat_above = |x: f64| x > -0.5;
        assert_eq!(
            profile_bound(flat_above, 1.0, 0.05, LN_REACH),
            (LN_REACH, true)
        );
        // A reach that is not a doubling of the first step: the last step is cut to it,
        // so a crossing between the last doubling and the reach is still found.
        let (hi, open) = profile_bound(|x: f64| x <= 2.5, 1.0, 0.05, 3.0);
        assert!(!open && hi <= 2.5 && hi > 2.5 - 1.4 / 64.0, "{hi}");
        assert_eq!(
            profile_bound(|x: f64| x <= 3.5, 1.0, 0.05, 3.0),
            (3.0, true)
        );
    }

    /// The bound located on a cheap profile and confirmed by the exact one is the exact
    /// search's, bit for bit, whenever the cheap profile crosses within the exact one's
    /// last bracket (offset by 10⁻⁶ here, or far off on the open side), for two exact
    /// calls a side (one on an open side); where the cheap profile crosses elsewhere
    /// (off by 0.1), the confirmation fails and the exact search is made again: the same
    /// bound still.
    #[test]
    fn a_confirmed_bound_is_the_exact_search_s() {
        let calls = Cell::new(0);
        let exact = |x: f64| {
            calls.set(calls.get() + 1);
            (x - 0.3f64).powi(2) <= 0.9
        };
        for off in [1e-6, -1e-6, 0.1, -0.1] {
            let near = |x: f64| (x - 0.3f64).powi(2) <= 0.9 + off;
            for dir in [1.0, -1.0] {
                calls.set(0);
                let want = profile_bound(exact, dir, 0.05, LN_REACH);
                let exact_calls = calls.get();
                calls.set(0);
                let got = profile_bound_confirmed(near, exact, dir, 0.05, LN_REACH);
                assert_eq!(got, want, "offset {off}, side {dir}");
                if off.abs() < 1e-3 {
                    assert_eq!(calls.get(), 2, "offset {off}, side {dir}");
                } else {
                    // One or two calls to find it unconfirmed, then the exact search.
                    let extra = calls.get() - exact_calls;
                    assert!((1..=2).contains(&extra), "offset {off}, side {dir}");
                }
            }
        }
        // Open above on both: one exact call, at the reach.
        calls.set(0);
        let flat = |x: f64| {
            calls.set(calls.get() + 1);
            x > -0.5
        };
        assert_eq!(
            profile_bound_confirmed(|x: f64| x > -0.6, flat, 1.0, 0.05, LN_REACH),
            (LN_REACH, true)
        );
        assert_eq!(calls.get(), 1);
        // Open on the cheap profile, closed on the exact one: found by the exact search.
        assert_eq!(
            profile_bound_confirmed(|_: f64| true, |x: f64| x <= 2.5, 1.0, 0.05, 3.0),
            profile_bound(|x: f64| x <= 2.5, 1.0, 0.05, 3.0)
        );
    }
}
