//! The statistics of gathered columns a pass over a run's rows keeps beside its moments:
//! how many values are nonzero, their sum and their extremes.

/// Of each of the m gathered columns of k values (column after column in `x`): the number
/// of its nonzero values, their sum Σv (added in row order: a zero adds nothing, so this
/// is the sum of every value in order) and its least and largest values (zeros
/// included). [`STAT_COLUMNS`] columns are taken side by side, each in row order: their
/// sums' chains of dependent additions overlap, and the extremes take no branches.
#[inline(always)]
pub(super) fn column_stats(x: &[f64], k: usize, m: usize) -> Vec<(usize, f64, f64, f64)> {
    let mut out = Vec::with_capacity(m);
    for j0 in (0..m).step_by(STAT_COLUMNS) {
        // A last group short of columns repeats its first (the repeats are dropped).
        let cols: [&[f64]; STAT_COLUMNS] = std::array::from_fn(|c| {
            let j = if j0 + c < m { j0 + c } else { j0 };
            &x[j * k..(j + 1) * k]
        });
        let mut n = [0usize; STAT_COLUMNS];
        let mut sum = [0.0; STAT_COLUMNS];
        let mut lo = [f64::INFINITY; STAT_COLUMNS];
        let mut hi = [f64::NEG_INFINITY; STAT_COLUMNS];
        for i in 0..k {
            for c in 0..STAT_COLUMNS {
                let v = cols[c][i];
                n[c] += usize::from(v != 0.0);
                sum[c] += v;
                lo[c] = if v < lo[c] { v } else { lo[c] };
                hi[c] = if v > hi[c] { v } else { hi[c] };
            }
        }
        out.extend((0..STAT_COLUMNS.min(m - j0)).map(|c| (n[c], sum[c], lo[c], hi[c])));
    }
    out
}

/// Columns of [`column_stats`] taken together.
const STAT_COLUMNS: usize = 4;
