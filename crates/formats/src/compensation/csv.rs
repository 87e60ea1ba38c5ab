//! A plain CSV of the compensation table with ISO 230-1 names, in the units of mtcal's
//! results (µm, µrad, positions in mm): one row per term and position, `#` comment lines
//! first.
//!
//! ```text
//! # mtcal compensation table: …
//! term,axis,position_mm,error,unit,error_forward,error_reverse
//! EXX,X,-200.000000,1.234567,um,-1.745433,4.214567
//! EYX,X,-200.000000,0.500000,um,,
//! EC0Y,,,12.345678,urad,,
//! thermal_scale,X,,11.500000,ppm/K,,
//! ```
//!
//! This is mtcal's own layout (no published example to follow): a squareness row has no
//! axis and no position. Where the diagnosis found a reversal of an axis, the rows of its
//! error along itself (EXX of X) carry the error travelling forward (toward +) and in
//! reverse, `error ∓ b/2` (`physics`); other rows leave both empty. A thermal coefficient
//! per kelvin is a row `thermal_offset` (um/K) or `thermal_scale` (ppm/K) with its axis
//! and no position. A file of the earlier five columns (no forward/reverse) still reads.

use super::{Compensation, Thermal, ThermalKind, squareness_from};
use crate::FormatError;
use mtcal_solver::terms::Term;
use std::fmt::Write as _;

/// Column names of the plain CSV.
pub const COLUMNS: [&str; 7] = [
    "term",
    "axis",
    "position_mm",
    "error",
    "unit",
    "error_forward",
    "error_reverse",
];

/// Writes `c` as a plain CSV (µm and µrad, 6 decimals).
pub fn write(c: &Compensation) -> String {
    let mut s = c.header_comment(
        "#",
        "plain CSV, ISO 230-1 names",
        "errors in um (translations) and urad (rotations), positions in mm",
        super::Format::Csv.carries(),
    );
    let _ = writeln!(s, "{}", COLUMNS.join(","));
    for a in &c.axes {
        let own = a.positioning().map(|p| p.term.as_str());
        for col in &a.columns {
            let angular = Term::parse(&col.term).is_some_and(Term::is_angular);
            let (scale, unit) = if angular { (1e6, "urad") } else { (1e3, "um") };
            let reversal = a.reversal_mm.as_ref().filter(|_| own == Some(&col.term));
            for (k, (q, v)) in a.positions_mm.iter().zip(&col.values).enumerate() {
                let _ = write!(s, "{},{},{q:.6},{:.6},{unit},", col.term, a.axis, v * scale);
                match reversal {
                    Some(b) => {
                        let half = b[k] * 0.5;
                        let _ = writeln!(s, "{:.6},{:.6}", (v - half) * scale, (v + half) * scale);
                    }
                    None => s.push_str(",\n"),
                }
            }
        }
    }
    for (n, v) in &c.squareness {
        let _ = writeln!(s, "{n},,,{:.6},urad,,", v * 1e6);
    }
    for t in &c.thermal {
        let axis = t.axis.map_or(String::new(), |a| a.to_string());
        let _ = writeln!(
            s,
            "{},{axis},,{:.6},{},,",
            t.kind.term(),
            t.per_k,
            t.kind.unit()
        );
    }
    s
}

/// Reads the plain CSV [`write`] makes.
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    let mut seen_header = false;
    let mut width = COLUMNS.len();
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
            if f != COLUMNS && f != COLUMNS[..5] {
                return Err(FormatError::new(
                    name,
                    n,
                    "",
                    format!("the header must be `{}`", COLUMNS.join(",")),
                ));
            }
            width = f.len();
            seen_header = true;
            continue;
        }
        if f.len() != width {
            return Err(FormatError::new(
                name,
                n,
                "",
                format!("{} fields where the header names {width}", f.len()),
            ));
        }
        let value = super::number(name, n as usize, "error", f[3])?;
        if let Some(kind) = ThermalKind::parse(f[0]) {
            thermal(&mut c, name, n, kind, &f, value)?;
            continue;
        }
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
        if width == COLUMNS.len() {
            reversal(&mut c, name, n, t, &f)?;
        }
    }
    if !seen_header {
        return Err(FormatError::file(name, "no header line"));
    }
    super::finish(name, c)
}

/// A thermal coefficient row: its axis, its unit, no position.
fn thermal(
    c: &mut Compensation,
    name: &str,
    n: u64,
    kind: ThermalKind,
    f: &[&str],
    value: f64,
) -> Result<(), FormatError> {
    let axis =
        match f[1] {
            "" => None,
            a => Some(super::axis_of(a).ok_or_else(|| {
                FormatError::new(name, n, "axis", format!("`{a}` is not X, Y or Z"))
            })?),
        };
    if f[4] != kind.unit() {
        return Err(FormatError::new(
            name,
            n,
            "unit",
            format!("`{}`: {} is in {}", f[4], kind.term(), kind.unit()),
        ));
    }
    c.thermal.push(Thermal {
        axis,
        kind,
        per_k: value,
    });
    Ok(())
}

/// The forward/reverse cells of a row of term `t`: both empty,
/// or both numbers on a row of an axis's error along itself, where they give the lost
/// motion b = reverse − forward at the row's position (mm).
fn reversal(
    c: &mut Compensation,
    name: &str,
    n: u64,
    t: Term,
    f: &[&str],
) -> Result<(), FormatError> {
    let (fw, rv) = (f[5], f[6]);
    if fw.is_empty() && rv.is_empty() {
        return Ok(());
    }
    if t.kind() != mtcal_solver::terms::TermKind::Positioning {
        return Err(FormatError::new(
            name,
            n,
            "error_forward",
            format!(
                "forward and reverse values belong to an axis's error along itself, not {}",
                t.code()
            ),
        ));
    }
    let fw = super::number(name, n as usize, "error_forward", fw)?;
    let rv = super::number(name, n as usize, "error_reverse", rv)?;
    let a = c
        .axes
        .iter_mut()
        .find(|a| a.axis == t.axis)
        .unwrap_or_else(|| unreachable!("the row was just added"));
    let k = a
        .columns
        .iter()
        .find(|col| col.term == t.code())
        .map_or(0, |col| col.values.len() - 1);
    let b = a.reversal_mm.get_or_insert_with(Vec::new);
    if b.len() != k {
        return Err(FormatError::new(
            name,
            n,
            "error_forward",
            format!(
                "forward and reverse values on some rows of {} but not on others",
                t.code()
            ),
        ));
    }
    b.push((rv - fw) * 1e-3);
    Ok(())
}
