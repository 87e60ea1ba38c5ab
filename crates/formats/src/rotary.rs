//! Rotary-axis point sets (datasets contract, section 2; `docs/datasets.md`): measured
//! ball-centre positions (instrument frame) at commanded A and C of a 5-axis cradle.
//!
//! CSV: `a_deg, c_deg, x_mm, y_mm, z_mm` required, `t_s` optional (strictly increasing
//! over the file), one point per line, at least one point. Sidecar JSON (same stem,
//! `.json`): `machine_id` (non-empty string) and `measured_at` (RFC 3339) required,
//! `nominal_radius_mm` optional (finite, > 0), unknown fields rejected unless `x-`.

use crate::csv_core::{CsvTable, check_increasing};
use crate::csv_out::CsvOut;
use crate::json::JsonDoc;
use crate::limits::Quantity;
use crate::{FormatError, Limits, invalid_input};
use mtcal_solver::datasets::{RotaryPoint, RotaryPointSet};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Columns of a rotary point set, required first.
pub const ROTARY_COLUMNS: [&str; 6] = ["a_deg", "c_deg", "x_mm", "y_mm", "z_mm", "t_s"];

/// The sidecar name of a point-set file: its stem (without `.gz` and `.csv`) + `.json`.
pub fn sidecar_name(name: &str) -> String {
    let stem = name.strip_suffix(".gz").unwrap_or(name);
    let stem = stem.strip_suffix(".csv").unwrap_or(stem);
    format!("{stem}.json")
}

/// Reads a point set `name` (CSV, possibly gzip) with its optional sidecar.
pub fn read_rotary_points(
    name: &str,
    csv: &[u8],
    sidecar_json: Option<&[u8]>,
    limits: &Limits,
) -> Result<RotaryPointSet, FormatError> {
    let (machine_id, measured_at, nominal_radius_mm) = match sidecar_json {
        None => (None, None, None),
        Some(bytes) => read_sidecar(&sidecar_name(name), bytes)?,
    };
    let data = crate::decode_single(name, csv, limits)?;
    let mut t = CsvTable::open(name, &data, limits)?;
    let c = t.check_schema(&ROTARY_COLUMNS, 5)?;
    let c_t = t.col("t_s");
    let mut numbers = vec![(c[0], Quantity::Angle), (c[1], Quantity::Angle)];
    numbers.extend(c[2..5].iter().map(|&i| (i, Quantity::Position)));
    numbers.extend(c_t.map(|i| (i, Quantity::Time)));
    t.scan(&numbers);
    let mut points = Vec::with_capacity(t.remaining_rows_hint());
    let mut prev_t = None;
    while t.next_row()? {
        let t_s = match c_t {
            Some(ct) => {
                let v = t.quantity(ct, Quantity::Time)?;
                check_increasing(&t, ct, prev_t, v, "the file")?;
                prev_t = Some(v);
                Some(v)
            }
            None => None,
        };
        points.push(RotaryPoint {
            a_deg: t.quantity(c[0], Quantity::Angle)?,
            c_deg: t.quantity(c[1], Quantity::Angle)?,
            x_mm: t.quantity(c[2], Quantity::Position)?,
            y_mm: t.quantity(c[3], Quantity::Position)?,
            z_mm: t.quantity(c[4], Quantity::Position)?,
            t_s,
        });
    }
    if points.is_empty() {
        return Err(t.header_error("", "the file has no points after the header"));
    }
    points.shrink_to_fit();
    let a: Vec<f64> = points.iter().map(|p| p.a_deg).collect();
    let c: Vec<f64> = points.iter().map(|p| p.c_deg).collect();
    crate::units::check_degrees(name, &a, &c)?;
    Ok(RotaryPointSet {
        machine_id,
        measured_at,
        nominal_radius_mm,
        points,
    })
}

type Sidecar = (Option<String>, Option<String>, Option<f64>);

fn read_sidecar(file: &str, bytes: &[u8]) -> Result<Sidecar, FormatError> {
    let doc = JsonDoc::parse(file, bytes)?;
    let root = doc.root()?;
    root.check_fields(&["machine_id", "measured_at", "nominal_radius_mm"])?;
    let machine_id = root.req_str("machine_id")?.to_string();
    root.req_str("measured_at")?;
    let measured_at = root.opt_timestamp("measured_at")?.map(str::to_string);
    let radius = root.opt_f64("nominal_radius_mm")?;
    if let Some(r) = radius
        && r <= 0.0
    {
        return Err(root.error("nominal_radius_mm", "must be a positive number (mm)"));
    }
    Ok((Some(machine_id), measured_at, radius))
}

/// Reads a point set from a file; the sidecar `<stem>.json` next to it is read when it
/// exists.
pub fn read_rotary_points_path(
    path: &Path,
    limits: &Limits,
) -> Result<RotaryPointSet, FormatError> {
    let (name, data) = crate::read_single(path, limits)?;
    let sidecar_path: PathBuf = path.with_file_name(sidecar_name(&name));
    let sidecar = if sidecar_path.is_file() {
        Some(crate::read_file_limited(
            &sidecar_path,
            &sidecar_name(&name),
            limits,
        )?)
    } else {
        None
    };
    read_rotary_points(&name, &data, sidecar.as_deref(), limits)
}

/// Writes the CSV of a point set (`t_s` column when every point has a time).
pub fn write_rotary_points(w: impl Write, set: &RotaryPointSet) -> std::io::Result<()> {
    let with_t = set.points.first().is_some_and(|p| p.t_s.is_some());
    let mut prev = f64::NEG_INFINITY;
    for p in &set.points {
        if p.t_s.is_some() != with_t {
            return Err(invalid_input("t_s must be given for all points or none"));
        }
        let values = [
            p.a_deg,
            p.c_deg,
            p.x_mm,
            p.y_mm,
            p.z_mm,
            p.t_s.unwrap_or(0.0),
        ];
        if values.iter().any(|v| !v.is_finite()) {
            return Err(invalid_input("non-finite value in a rotary point"));
        }
        if let Some(t) = p.t_s {
            if t <= prev {
                return Err(invalid_input("t_s is not strictly increasing"));
            }
            prev = t;
        }
    }
    let names = ["a_deg", "c_deg", "x_mm", "y_mm", "z_mm", "t_s"];
    let mut out = CsvOut::with_header(w, names[..5 + usize::from(with_t)].iter().copied())?;
    for p in &set.points {
        out.numbers(
            [p.a_deg, p.c_deg, p.x_mm, p.y_mm, p.z_mm]
                .into_iter()
                .chain(p.t_s),
        )?;
        out.end_record()?;
    }
    out.finish()
}

/// Writes the sidecar JSON of a point set (machine_id and measured_at must be known).
pub fn write_rotary_sidecar(mut w: impl Write, set: &RotaryPointSet) -> std::io::Result<()> {
    let (Some(machine_id), Some(measured_at)) = (&set.machine_id, &set.measured_at) else {
        return Err(invalid_input("a sidecar needs machine_id and measured_at"));
    };
    let mut doc = serde_json::json!({"machine_id": machine_id, "measured_at": measured_at});
    if let Some(r) = set.nominal_radius_mm {
        if !(r.is_finite() && r > 0.0) {
            return Err(invalid_input(
                "nominal_radius_mm must be finite and positive",
            ));
        }
        doc["nominal_radius_mm"] = serde_json::json!(r);
    }
    serde_json::to_writer_pretty(&mut w, &doc).map_err(std::io::Error::other)?;
    w.write_all(b"\n")?;
    w.flush()
}
