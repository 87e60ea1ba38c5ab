//! ISG / Beckhoff TwinCAT CNC volumetric compensation, file format `ISG_CSV`.
//!
//! Layout as published by ISG (ISG kernel documentation, "ISG CSV format", and Beckhoff
//! TF5280 Volumetric Compensation): row comments start with `//`; a `#` line is a "file
//! break" after which a new header and its records follow; a header names the argument
//! (`X`) and the error parameters (`EXX EYX EZX EAX EBX ECX`), one record per line,
//! fields separated by blanks; position errors (squareness) form their own block with a
//! header of their names without the E (`C0Y B0Z A0Z`) and one record. Units (ISG "Units
//! of measure"): parameters in mm and rad, arguments in mm.

use super::{Compensation, position_error_name, squareness_from};
use crate::FormatError;
use mtcal_solver::terms::Term;
use std::fmt::Write as _;

/// Writes `c` as an ISG CSV file.
pub fn write(c: &Compensation) -> String {
    let mut s = c.header_comment(
        "//",
        "ISG CSV (volumetric compensation, file_format ISG_CSV)",
        "errors in mm and rad, arguments in mm",
        super::Format::Isg.carries(),
    );
    let mut first = true;
    if !c.squareness.is_empty() {
        let _ = writeln!(s, "// position errors (squareness), rad");
        let names: Vec<&str> = c
            .squareness
            .iter()
            .map(|(n, _)| position_error_name(n))
            .collect();
        let _ = writeln!(s, "{}", names.join(" "));
        let vals: Vec<String> = c
            .squareness
            .iter()
            .map(|(_, v)| format!("{v:.12}"))
            .collect();
        let _ = writeln!(s, "{}", vals.join(" "));
        first = false;
    }
    for a in &c.axes {
        if !first {
            let _ = writeln!(s, "#");
        }
        first = false;
        let _ = writeln!(
            s,
            "// component errors of {} (mm, rad) over its measured travel",
            a.axis
        );
        let mut head = vec![a.axis.letter().to_string()];
        head.extend(a.columns.iter().map(|col| col.term.clone()));
        let _ = writeln!(s, "{}", head.join(" "));
        for (k, q) in a.positions_mm.iter().enumerate() {
            let _ = write!(s, "{q:.6}");
            for col in &a.columns {
                let _ = write!(s, " {}", value(&col.term, col.values[k]));
            }
            s.push('\n');
        }
    }
    s
}

/// mm with 9 decimals (1 pm), rad with 12 (1e-6 µrad).
fn value(term: &str, v: f64) -> String {
    if Term::parse(term).is_some_and(Term::is_angular) {
        format!("{v:.12}")
    } else {
        format!("{v:.9}")
    }
}

/// Reads an ISG CSV file of component errors of X, Y, Z (argument: the moving axis) and
/// the position errors C0Y, B0Z, A0Z.
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    let mut header: Option<(usize, Vec<String>)> = None;
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.split("//").next().unwrap_or("").trim();
        super::comment(&mut c, raw, "//");
        if line.is_empty() {
            continue;
        }
        if line == "#" {
            header = None;
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let Some((_, cols)) = &header else {
            header = Some((n, header_of(name, n, &fields)?));
            continue;
        };
        if fields.len() != cols.len() {
            return Err(FormatError::new(
                name,
                n as u64,
                "",
                format!(
                    "{} fields where the header names {}",
                    fields.len(),
                    cols.len()
                ),
            ));
        }
        let cells: Vec<f64> = fields
            .iter()
            .zip(cols)
            .map(|(f, col)| super::number(name, n, col, f))
            .collect::<Result<_, _>>()?;
        if squareness_from(&cols[0]).is_some() {
            for (col, v) in cols.iter().zip(&cells) {
                let sq = squareness_from(col).unwrap_or_default();
                if c.squareness.iter().any(|(s, _)| s == sq) {
                    return Err(FormatError::new(
                        name,
                        n as u64,
                        col.as_str(),
                        "given twice",
                    ));
                }
                c.squareness.push((sq.to_string(), *v));
            }
            continue;
        }
        for (col, v) in cols.iter().zip(&cells).skip(1) {
            let term = Term::parse(col).unwrap_or_else(|| unreachable!("checked in the header"));
            super::push_point(&mut c.axes, term, cells[0], *v)
                .map_err(|rule| FormatError::new(name, n as u64, col.as_str(), rule))?;
        }
    }
    super::finish(name, c)
}

/// Checks a header: either position errors only, or an axis argument followed by that
/// axis's component errors.
fn header_of(name: &str, n: usize, fields: &[&str]) -> Result<Vec<String>, FormatError> {
    let err = |col: &str, rule: String| FormatError::new(name, n as u64, col, rule);
    if squareness_from(fields[0]).is_some() {
        for f in fields {
            if squareness_from(f).is_none() {
                return Err(err(
                    f,
                    format!("`{f}`: a position-error header holds only C0Y, B0Z, A0Z"),
                ));
            }
        }
    } else {
        let axis = super::axis_of(fields[0]).ok_or_else(|| {
            err(
                fields[0],
                format!(
                    "`{}` is not an argument (X, Y, Z) or a position error",
                    fields[0]
                ),
            )
        })?;
        if fields.len() < 2 {
            return Err(err(fields[0], "a header names at least one error".into()));
        }
        for f in &fields[1..] {
            match Term::parse(f) {
                Some(t) if t.axis == axis => {}
                _ => {
                    return Err(err(
                        f,
                        format!("`{f}` is not a component error of {axis} (E[XYZABC]{axis})"),
                    ));
                }
            }
        }
    }
    Ok(fields.iter().map(|f| f.to_string()).collect())
}
