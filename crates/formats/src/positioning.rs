//! Positioning runs (datasets contract, section 3; `docs/datasets.md`), ISO 230-2 style.
//!
//! CSV: `axis` (X, Y or Z), `run` (integer: the bidirectional cycle), `direction` (`+` or
//! `-`: the approach direction), `target_mm`, `deviation_um` required; `t_s` (strictly
//! increasing within each axis and run) and `temp_c` optional; at least one row.

use crate::csv_core::{CsvTable, check_increasing};
use crate::csv_out::CsvOut;
use crate::limits::Quantity;
use crate::{FormatError, Limits, invalid_input};
use mtcal_solver::Axis;
use mtcal_solver::datasets::{Direction, PositioningRecord, PositioningRuns};
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

/// Columns of a positioning file, required first.
pub const POSITIONING_COLUMNS: [&str; 7] = [
    "axis",
    "run",
    "direction",
    "target_mm",
    "deviation_um",
    "t_s",
    "temp_c",
];

/// Reads positioning runs from `bytes` (CSV, possibly gzip) named `name`.
pub fn read_positioning(
    name: &str,
    bytes: &[u8],
    limits: &Limits,
) -> Result<PositioningRuns, FormatError> {
    let data = crate::decode_single(name, bytes, limits)?;
    let mut t = CsvTable::open(name, &data, limits)?;
    let c = t.check_schema(&POSITIONING_COLUMNS, 5)?;
    let (c_t, c_temp) = (t.col("t_s"), t.col("temp_c"));
    let numbers = [(c[3], Quantity::Position), (c[4], Quantity::Deviation)];
    let optional = [(c_t, Quantity::Time), (c_temp, Quantity::Temperature)];
    let optional = optional.iter().filter_map(|&(c, q)| Some((c?, q)));
    t.scan(&numbers.into_iter().chain(optional).collect::<Vec<_>>());
    let mut records = Vec::with_capacity(t.remaining_rows_hint());
    let mut last_t: HashMap<(Axis, i64), f64> = HashMap::new();
    while t.next_row()? {
        let a = t.text(c[0]);
        let axis = match a {
            "X" => Axis::X,
            "Y" => Axis::Y,
            "Z" => Axis::Z,
            _ => return Err(t.cell_error(c[0], format!("`{a}` is not an axis (X, Y or Z)"))),
        };
        let run = t.int(c[1])?;
        let d = t.text(c[2]);
        let direction = match d {
            "+" => Direction::Plus,
            "-" => Direction::Minus,
            _ => return Err(t.cell_error(c[2], format!("`{d}` is not a direction (+ or -)"))),
        };
        let t_s = match c_t {
            Some(ct) => {
                let v = t.quantity(ct, Quantity::Time)?;
                let prev = last_t.insert((axis, run), v);
                check_increasing(&t, ct, prev, v, format_args!("axis {axis} run {run}"))?;
                Some(v)
            }
            None => None,
        };
        records.push(PositioningRecord {
            axis,
            run,
            direction,
            target_mm: t.quantity(c[3], Quantity::Position)?,
            deviation_um: t.quantity(c[4], Quantity::Deviation)?,
            t_s,
            temp_c: c_temp
                .map(|ct| t.quantity(ct, Quantity::Temperature))
                .transpose()?,
        });
    }
    if records.is_empty() {
        return Err(t.header_error("", "the file has no rows after the header"));
    }
    records.shrink_to_fit();
    let deviations: Vec<f64> = records.iter().map(|r| r.deviation_um).collect();
    crate::units::check_micrometres(name, "deviation_um", [deviations.as_slice()])?;
    Ok(PositioningRuns { records })
}

/// Reads positioning runs from a file (gzip accepted).
pub fn read_positioning_path(path: &Path, limits: &Limits) -> Result<PositioningRuns, FormatError> {
    let (name, data) = crate::read_single(path, limits)?;
    read_positioning(&name, &data, limits)
}

/// Writes positioning runs (`t_s`, `temp_c` columns when every record has them).
pub fn write_positioning(w: impl Write, runs: &PositioningRuns) -> std::io::Result<()> {
    let first = runs.records.first();
    let with_t = first.is_some_and(|r| r.t_s.is_some());
    let with_temp = first.is_some_and(|r| r.temp_c.is_some());
    let mut last_t: HashMap<(Axis, i64), f64> = HashMap::new();
    for r in &runs.records {
        if r.t_s.is_some() != with_t || r.temp_c.is_some() != with_temp {
            return Err(invalid_input(
                "t_s and temp_c must be given for all records or none",
            ));
        }
        let values = [r.target_mm, r.deviation_um]
            .into_iter()
            .chain(r.t_s)
            .chain(r.temp_c);
        if values.into_iter().any(|v| !v.is_finite()) {
            return Err(invalid_input("non-finite value in a positioning record"));
        }
        if let Some(t) = r.t_s
            && last_t.insert((r.axis, r.run), t).is_some_and(|p| t <= p)
        {
            return Err(invalid_input("t_s is not strictly increasing within a run"));
        }
    }
    let optional = [("t_s", with_t), ("temp_c", with_temp)];
    let names = ["axis", "run", "direction", "target_mm", "deviation_um"]
        .into_iter()
        .chain(optional.into_iter().filter(|c| c.1).map(|c| c.0));
    let mut out = CsvOut::with_header(w, names)?;
    for r in &runs.records {
        let dir = match r.direction {
            Direction::Plus => "+",
            Direction::Minus => "-",
        };
        out.text(&r.axis.to_string())?;
        out.text(&r.run.to_string())?;
        out.text(dir)?;
        out.numbers(
            [r.target_mm, r.deviation_um]
                .into_iter()
                .chain(r.t_s)
                .chain(r.temp_c),
        )?;
        out.end_record()?;
    }
    out.finish()
}
