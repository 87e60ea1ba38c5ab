//! The statistics of gathered columns a pass over a run's rows keeps beside its moments:
//! how many values are nonzero, their sum and their extremes.

/// Of each of the m gathered columns of k values (column after column in `x`): the number
/// of its nonzero values, their sum Σv (added in row order: a zero adds nothing, so this
/// is the sum of every value in order) and its least and largest values (zeros
/// included). [`STAT_COLUMNS`] columns are taken side by side, each in row order: their
/// sums' chains of dependent additions overlap, and the extremes take no branches; the
/// last columns, fewer, side by side as many as they are.
#[inline(always)]
pub(super) fn column_stats(x: &[f64], k: usize, m: usize) -> Vec<(usize, f64, f64, f64)> {
    let mut out = Vec::with_capacity(m);
    let full = m - m % STAT_COLUMNS;
    for j0 in (0..full).step_by(STAT_COLUMNS) {
        group::<STAT_COLUMNS>(x, k, j0, &mut out);
    }
    match m - full {
        1 => group::<1>(x, k, full, &mut out),
        2 => group::<2>(x, k, full, &mut out),
        3 => group::<3>(x, k, full, &mut out),
        _ => {}
    }
    out
}

/// [`column_stats`] of the L columns from `j0`, appended to `out`.
#[inline(always)]
fn group<const L: usize>(x: &[f64], k: usize, j0: usize, out: &mut Vec<(usize, f64, f64, f64)>) {
    let cols: [&[f64]; L] = std::array::from_fn(|c| &x[(j0 + c) * k..(j0 + c + 1) * k]);
    let mut n = [0usize; L];
    let mut sum = [0.0; L];
    let mut lo = [f64::INFINITY; L];
    let mut hi = [f64::NEG_INFINITY; L];
    for i in 0..k {
        for c in 0..L {
            let v = cols[c][i];
            n[c] += usize::from(v != 0.0);
            sum[c] += v;
            lo[c] = if v < lo[c] { v } else { lo[c] };
            hi[c] = if v > hi[c] { v } else { hi[c] };
        }
    }
    out.extend((0..L).map(|c| (n[c], sum[c], lo[c], hi[c])));
}

/// Columns of [`column_stats`] taken together.
const STAT_COLUMNS: usize = 4;
