//! A plain CSV of the compensation table with ISO 230-1 names, in the units of mtcal's
//! results (µm, µrad, positions in mm): one row per term and position, `#` comment lines
//! first.
//!
//! ```text
//! # mtcal compensation table: …
//! term,axis,position_mm,error,unit
//! EXX,X,-200.000000,1.234567,um
//! EC0Y,,,12.345678,urad
//! ```
//!
//! This is mtcal's own layout (no published example to follow): a squareness row has no
//! axis and no position.

use super::{Compensation, squareness_from};
use crate::FormatError;
use mtcal_solver::terms::Term;
use std::fmt::Write as _;

/// Column names of the plain CSV.
pub const COLUMNS: [&str; 5] = ["term", "axis", "position_mm", "error", "unit"];

/// Writes `c` as a plain CSV (µm and µrad, 6 decimals).
pub fn write(c: &Compensation) -> String {
    let mut s = c.header_comment(
        "#",
        "plain CSV, ISO 230-1 names",
        "errors in um (translations) and urad (rotations), positions in mm",
    );
    let _ = writeln!(s, "{}", COLUMNS.join(","));
    for a in &c.axes {
        for col in &a.columns {
            let angular = Term::parse(&col.term).is_some_and(Term::is_angular);
            let (scale, unit) = if angular { (1e6, "urad") } else { (1e3, "um") };
            for (q, v) in a.positions_mm.iter().zip(&col.values) {
                let _ = writeln!(s, "{},{},{q:.6},{:.6},{unit}", col.term, a.axis, v * scale);
            }
        }
    }
    for (n, v) in &c.squareness {
        let _ = writeln!(s, "{n},,,{:.6},urad", v * 1e6);
    }
    s
}

/// Reads the plain CSV [`write`] makes.
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    let mut seen_header = false;
    for (i, raw) in text.lines().enumerate() {
        let n = (i + 1) as u64;
        let line = raw.trim();
        if super::comment(&mut c, line, "#") {
            continue;
        }
        if line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if !seen_header {
            if f != COLUMNS {
                return Err(FormatError::new(
                    name,
                    n,
                    "",
                    format!("the header must be `{}`", COLUMNS.join(",")),
                ));
            }
            seen_header = true;
            continue;
        }
        if f.len() != COLUMNS.len() {
            return Err(FormatError::new(
                name,
                n,
                "",
                format!(
                    "{} fields where the header names {}",
                    f.len(),
                    COLUMNS.len()
                ),
            ));
        }
        let value = super::number(name, n as usize, "error", f[3])?;
        if let Some(sq) = squareness_from(f[0]) {
            if f[4] != "urad" {
                return Err(FormatError::new(name, n, "unit", "a squareness is in urad"));
            }
            if c.squareness.iter().any(|(s, _)| s == sq) {
                return Err(FormatError::new(
                    name,
                    n,
                    "term",
                    format!("{sq} given twice"),
                ));
            }
            c.squareness.push((sq.to_string(), value * 1e-6));
            continue;
        }
        let t = Term::parse(f[0]).ok_or_else(|| {
            FormatError::new(
                name,
                n,
                "term",
                format!("`{}` is not an ISO 230-1 term of X, Y, Z", f[0]),
            )
        })?;
        if f[1] != t.axis.to_string() {
            return Err(FormatError::new(
                name,
                n,
                "axis",
                format!("`{}`: {} is a term of {}", f[1], t.code(), t.axis),
            ));
        }
        let want = t.unit();
        if f[4] != want {
            return Err(FormatError::new(
                name,
                n,
                "unit",
                format!("`{}`: {} is in {want}", f[4], t.code()),
            ));
        }
        let q = super::number(name, n as usize, "position_mm", f[2])?;
        let scale = if t.is_angular() { 1e-6 } else { 1e-3 };
        super::push_point(&mut c.axes, t, q, value * scale)
            .map_err(|rule| FormatError::new(name, n, "position_mm", rule))?;
    }
    if !seen_header {
        return Err(FormatError::file(name, "no header line"));
    }
    super::finish(name, c)
}
