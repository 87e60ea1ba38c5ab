//! Interim strict reader of measurement sessions (datasets contract, section 1), used
//! until `mtcal_formats::read_session_files` lands on main; it returns the same
//! [`FormatError`] (file, line, column, rule). Replace [`parse`]'s body by a call to the
//! formats crate then, and delete the rest of this module.

use mtcal_formats::FormatError;
use mtcal_solver::axis::{Axis, Plane, Topology};
use mtcal_solver::session::{PlaneRecord, Run, Session, TestKind};
use serde_json::Value;
use std::collections::BTreeMap;

fn err(file: &str, line: u64, column: &str, rule: impl Into<String>) -> FormatError {
    FormatError {
        file: file.into(),
        line,
        column: column.into(),
        rule: rule.into(),
    }
}

fn axes(v: &Value, field: &str) -> Result<Vec<Axis>, FormatError> {
    v.as_array()
        .ok_or_else(|| err("session.json", 0, field, "must be a list of axis letters"))?
        .iter()
        .map(|a| {
            a.as_str()
                .and_then(Axis::parse)
                .ok_or_else(|| err("session.json", 0, field, "axis must be X, Y or Z"))
        })
        .collect()
}

/// Parses `session.json` and its plane files (already decompressed, keyed by name).
pub fn parse(
    session_json: &[u8],
    files: &BTreeMap<String, Vec<u8>>,
    max_samples: usize,
) -> Result<Session, FormatError> {
    const SJ: &str = "session.json";
    let v: Value = serde_json::from_slice(session_json)
        .map_err(|e| err(SJ, e.line() as u64, "", format!("not valid JSON: {e}")))?;
    let text = |f: &str, required: bool| -> Result<Option<String>, FormatError> {
        match v.get(f) {
            Some(Value::String(s)) => Ok(Some(s.clone())),
            None | Some(Value::Null) if !required => Ok(None),
            _ => Err(err(SJ, 0, f, "required text field")),
        }
    };
    let machine_id = text("machine_id", true)?.unwrap_or_default();
    let measured_at = text("measured_at", true)?.unwrap_or_default();
    time::OffsetDateTime::parse(&measured_at, &time::format_description::well_known::Rfc3339)
        .map_err(|_| err(SJ, 0, "measured_at", "must be an RFC 3339 time stamp"))?;
    let topology = match v.get("topology") {
        None | Some(Value::Null) => None,
        Some(t) => Some(Topology {
            workpiece: axes(&t["workpiece"], "topology.workpiece")?,
            tool: axes(&t["tool"], "topology.tool")?,
        }),
    };
    let temperature_c = match v.get("temperature_c") {
        None | Some(Value::Null) => None,
        Some(t) => Some(
            t.as_f64()
                .ok_or_else(|| err(SJ, 0, "temperature_c", "must be a number"))?,
        ),
    };
    let planes_v = v["planes"]
        .as_array()
        .filter(|p| !p.is_empty())
        .ok_or_else(|| err(SJ, 0, "planes", "must be a non-empty list"))?;
    let mut planes = Vec::new();
    for (i, p) in planes_v.iter().enumerate() {
        let col = |f: &str| format!("planes[{i}].{f}");
        let file = p["file"]
            .as_str()
            .ok_or_else(|| err(SJ, 0, &col("file"), "required text field"))?
            .to_string();
        let plane = p["plane"]
            .as_str()
            .and_then(Plane::parse)
            .ok_or_else(|| err(SJ, 0, &col("plane"), "must be XY, XZ or YZ"))?;
        let off: Vec<f64> = p["head_offset_mm"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_f64).collect())
            .unwrap_or_default();
        let head_offset_mm: [f64; 3] = off
            .try_into()
            .map_err(|_| err(SJ, 0, &col("head_offset_mm"), "must be three numbers"))?;
        let mounting = p["mounting"].as_str().unwrap_or(&file).to_string();
        let bytes = files
            .get(&file)
            .ok_or_else(|| err(&file, 0, "", "file listed in session.json is missing"))?;
        let runs = parse_plane_csv(&file, bytes, max_samples)?;
        planes.push(PlaneRecord {
            file,
            plane,
            head_offset_mm,
            mounting,
            runs,
        });
    }
    Ok(Session {
        machine_id,
        measured_at,
        topology,
        temperature_c,
        notes: text("notes", false)?,
        planes,
    })
}

const REQUIRED: [&str; 7] = ["run", "t_s", "x_mm", "y_mm", "z_mm", "du_um", "dv_um"];

fn parse_plane_csv(file: &str, bytes: &[u8], max_samples: usize) -> Result<Vec<Run>, FormatError> {
    let text =
        std::str::from_utf8(bytes).map_err(|e| err(file, 0, "", format!("not UTF-8: {e}")))?;
    let mut header: Option<Vec<String>> = None;
    let mut idx: BTreeMap<&str, usize> = BTreeMap::new();
    let mut runs: Vec<Run> = Vec::new();
    let mut samples = 0usize;
    for (ln, line) in text.lines().enumerate() {
        let ln = ln as u64 + 1;
        let line = line.trim_end_matches('\r');
        if line.starts_with('#') || (line.trim().is_empty() && header.is_some()) {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(h) = &header else {
            for (i, c) in cells.iter().enumerate() {
                if c.starts_with("x-") {
                    continue;
                }
                if !(REQUIRED.contains(c) || *c == "temp_c" || *c == "test") {
                    return Err(err(
                        file,
                        ln,
                        c,
                        "unknown column (prefix it with x- to keep it)",
                    ));
                }
                if idx.insert(c, i).is_some() {
                    return Err(err(file, ln, c, "column given twice"));
                }
            }
            if let Some(missing) = REQUIRED.iter().find(|c| !idx.contains_key(*c)) {
                return Err(err(
                    file,
                    ln,
                    missing,
                    "required column missing from the header",
                ));
            }
            header = Some(cells.iter().map(|s| s.to_string()).collect());
            continue;
        };
        if cells.len() != h.len() {
            return Err(err(
                file,
                ln,
                "",
                format!("{} cells, header has {}", cells.len(), h.len()),
            ));
        }
        samples += 1;
        if samples > max_samples {
            return Err(err(
                file,
                ln,
                "",
                format!("more than {max_samples} samples"),
            ));
        }
        let num = |c: &str| -> Result<f64, FormatError> {
            let s = cells[idx[c]];
            match s.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(err(
                    file,
                    ln,
                    c,
                    format!("{s:?} is not a finite decimal number"),
                )),
            }
        };
        let run_no: i64 = cells[idx["run"]]
            .parse()
            .map_err(|_| err(file, ln, "run", "must be an integer"))?;
        let t = num("t_s")?;
        let new_run = runs.last().is_none_or(|r| r.number != run_no);
        if new_run {
            if runs.iter().any(|r| r.number == run_no) {
                return Err(err(
                    file,
                    ln,
                    "run",
                    format!("run {run_no} is not contiguous"),
                ));
            }
            let test = match idx.get("test") {
                Some(&i) if !cells[i].is_empty() => Some(
                    TestKind::parse(cells[i])
                        .ok_or_else(|| err(file, ln, "test", "unknown test label"))?,
                ),
                _ => None,
            };
            runs.push(Run {
                number: run_no,
                test,
                temp_c: idx.contains_key("temp_c").then(Vec::new),
                ..Run::default()
            });
        }
        let run = runs.last_mut().expect("pushed above");
        if run.t_s.last().is_some_and(|&last| t <= last) {
            return Err(err(
                file,
                ln,
                "t_s",
                "time must increase strictly within a run",
            ));
        }
        run.t_s.push(t);
        run.pos_mm.push([num("x_mm")?, num("y_mm")?, num("z_mm")?]);
        run.du_um.push(num("du_um")?);
        run.dv_um.push(num("dv_um")?);
        if let Some(tc) = run.temp_c.as_mut() {
            tc.push(num("temp_c")?);
        }
    }
    if header.is_none() {
        return Err(err(file, 1, "", "header required"));
    }
    if runs.is_empty() {
        return Err(err(file, 0, "", "no samples"));
    }
    Ok(runs)
}
