//! Unit mistakes a person makes when exporting a dataset, found on the data read (not in
//! the solver) and refused with the file, the column and what to change
//! (`docs/datasets.md`, "Unit mistakes"):
//!
//! * **millimetres in a micrometre column** (`du_um`, `dv_um`, `deviation_um`, a drift
//!   log's `<name>_um`): every value lies within ±0.001 µm (1 nm) and the column's noise
//!   floor is under 1 nm. No grid encoder, interferometer or probe resolves that (their
//!   noise is tens of nanometres), while a deviation of a few µm written in mm gives
//!   exactly such a column. An all-zero column is not refused (no factor changes it).
//!   The noise floor is the white-noise level of the second differences,
//!   σ = √(Σ (vᵢ₊₁ − 2vᵢ + vᵢ₋₁)² / 6n) over each run (second differences cancel a
//!   linear trend; for white noise of σ their variance is 6σ²);
//! * **micrometres in a millimetre column**: a position beyond the plausible bound of
//!   [`crate::Limits`] is refused at its cell with the hint to divide by 1000
//!   (`Quantity::hint`); below the bound, a plane file's positions moving faster than any
//!   machine axis traverses are refused by its reader (`check_speed`, in the CLI and the
//!   service alike), and at upload to the service [`crate::Dataset::check_travel`]
//!   compares the positions' span with the machine's registered travel;
//! * **radians in a degree column** (`a_deg`, `c_deg` of a rotary point set): every
//!   angle lies within ±2π while C turns through at least π/2 in those units. A cradle
//!   check turns C through tens of degrees at least, so a C span between 1.6 and 6.3
//!   with no angle beyond 6.3 is radians (the formats have no radian column, so the
//!   converse mistake cannot be told from the data).

use crate::FormatError;

/// Largest |value| of a micrometre column that looks like millimetres, µm (1 nm).
pub const MM_IN_UM_MAX: f64 = 1e-3;
/// A noise floor under this, µm (1 nm), is below any instrument's.
pub const MIN_NOISE_FLOOR_UM: f64 = 1e-3;
/// Factor above the machine's travel span from which positions are micrometres.
pub const TRAVEL_SPAN_FACTOR: f64 = 100.0;

/// Fastest feed a machine tool axis traverses at, mm/s (200 m/min: the rapid traverse
/// of fast linear-motor machines; a grid encoder's head reads far slower).
pub const MAX_AXIS_SPEED_MM_S: f64 = 200_000.0 / 60.0;

/// Refuses the positions of a plane file (`x_mm`, `y_mm`, `z_mm`, its runs' times `t_s`
/// and positions) that move faster than any machine tool axis traverses: the median speed
/// of the steps between consecutive samples of a run that move, |Δp|/Δt, above
/// [`MAX_AXIS_SPEED_MM_S`]. The error names the column that moves most. Positions written in micrometres move 1000× faster than the
/// machine did: a test at 200 mm/min or faster is caught whatever the machine's travel.
/// The median ignores a few glitches; a slower test in micrometres is caught against the
/// registered travel when uploaded to the service ([`check_span`]).
pub(crate) fn check_speed<'a>(
    file: &str,
    runs: impl IntoIterator<Item = (&'a [f64], &'a [[f64; 3]])>,
) -> Result<(), FormatError> {
    let mut speeds: Vec<f64> = vec![];
    // How far each position column moves in all, to name the one that moves most.
    let mut moved = [0.0f64; 3];
    for (t, p) in runs {
        for (tw, pw) in t.windows(2).zip(p.windows(2)) {
            let dt = tw[1] - tw[0];
            let dp = (0..3)
                .map(|k| (pw[1][k] - pw[0][k]).powi(2))
                .sum::<f64>()
                .sqrt();
            if dt > 0.0 && dp > 0.0 {
                speeds.push(dp / dt);
            }
            for (k, m) in moved.iter_mut().enumerate() {
                *m += (pw[1][k] - pw[0][k]).abs();
            }
        }
    }
    if speeds.is_empty() {
        return Ok(());
    }
    let mid = speeds.len() / 2;
    let median = *speeds.select_nth_unstable_by(mid, f64::total_cmp).1;
    if median <= MAX_AXIS_SPEED_MM_S {
        return Ok(());
    }
    let column = ["x_mm", "y_mm", "z_mm"][(0..3)
        .max_by(|&a, &b| moved[a].total_cmp(&moved[b]))
        .unwrap_or(0)];
    Err(FormatError::new(
        file,
        0,
        column,
        format!(
            "the positions move at {:.0} mm/s ({:.0} m/min) between samples (median over the \
             runs), faster than any machine tool axis traverses ({:.0} m/min): micrometres \
             where millimetres are required? divide x_mm, y_mm and z_mm by 1000",
            median,
            median * 0.06,
            MAX_AXIS_SPEED_MM_S * 0.06
        ),
    ))
}

/// White-noise level of the second differences over the series (see the module
/// documentation); 0 when no series has three values.
pub fn noise_floor<'a>(series: impl IntoIterator<Item = &'a [f64]>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for s in series {
        for w in s.windows(3) {
            let d2 = w[2] - 2.0 * w[1] + w[0];
            sum += d2 * d2;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        (sum / (6.0 * n as f64)).sqrt()
    }
}

/// Refuses a micrometre column `column` of `file` (its values run by run) that holds
/// millimetres.
pub(crate) fn check_micrometres<'a>(
    file: &str,
    column: &str,
    series: impl IntoIterator<Item = &'a [f64]> + Clone,
) -> Result<(), FormatError> {
    let largest = series
        .clone()
        .into_iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if largest == 0.0 || largest > MM_IN_UM_MAX {
        return Ok(());
    }
    let floor = noise_floor(series);
    if floor >= MIN_NOISE_FLOOR_UM {
        return Ok(());
    }
    Err(FormatError::new(
        file,
        0,
        column,
        format!(
            "every value lies within ±{MM_IN_UM_MAX} µm (largest |value| {largest:e}, noise \
             floor {floor:.1e} µm, under 1 nm): no instrument resolves that, these look like \
             millimetres in a micrometre column; multiply the column by 1000"
        ),
    ))
}

/// Refuses the angle columns of a rotary point set (`a_deg`, `c_deg`) when they hold
/// radians.
pub(crate) fn check_degrees(file: &str, a_deg: &[f64], c_deg: &[f64]) -> Result<(), FormatError> {
    use std::f64::consts::{FRAC_PI_2, TAU};
    let largest = a_deg
        .iter()
        .chain(c_deg)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let (lo, hi) = c_deg
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let span = hi - lo;
    // Values are finite (the readers refuse others); an empty C column spans −∞.
    if largest > TAU || span < FRAC_PI_2 {
        return Ok(());
    }
    Err(FormatError::new(
        file,
        0,
        "c_deg",
        format!(
            "every angle of a_deg and c_deg lies within ±2π (largest |value| {largest}) while \
             C turns through {span}: these look like radians in a degree column; multiply \
             a_deg and c_deg by 180/π (57.29578)"
        ),
    ))
}

/// Refuses positions of `column` in `file` whose span exceeds [`TRAVEL_SPAN_FACTOR`]
/// times the span of the machine's `travel` of `axis` (mm).
pub(crate) fn check_span(
    file: &str,
    column: &str,
    axis: &str,
    values: impl IntoIterator<Item = f64>,
    travel: [f64; 2],
) -> Result<(), FormatError> {
    let (lo, hi) = values
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(v), h.max(v))
        });
    let span = hi - lo;
    let travel_span = (travel[1] - travel[0]).abs();
    // A travel that is not a positive finite span checks nothing.
    if !travel_span.is_finite() || travel_span <= 0.0 || span <= TRAVEL_SPAN_FACTOR * travel_span {
        return Ok(());
    }
    Err(FormatError::new(
        file,
        0,
        column,
        format!(
            "the positions span {span} mm, {:.0}× the machine's {axis} travel of {travel_span} \
             mm ({} to {}): micrometres where millimetres are required? divide the column by \
             1000",
            span / travel_span,
            travel[0],
            travel[1]
        ),
    ))
}
