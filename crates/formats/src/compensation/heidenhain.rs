//! A Heidenhain KinematicsComp-style compensation table (`*.COM`), one per axis.
//!
//! No complete published example of a KinematicsComp `*.COM` file was found. The layout
//! follows what the HEIDENHAIN iTNC 530 HSCI Technical Manual describes: the
//! recommended scheme puts the component errors of a linear axis in columns C1…C6 of
//! its COM file (X: C1 = EXX, C2 = EYX, C3 = EZX, C4 = EAX, C5 = EBX, C6 = ECX), the
//! kinematics table refers to them (`Trans Y A..C2`), position errors (squareness) go
//! into the kinematics table's COORD column, not into a COM file; compensation-value
//! tables list their compensation points in a position column (AXISPOS on the
//! MANUALplus 620, ADDR here); TNC tables open with `BEGIN <name> MM` and close with
//! `[END]`. Units: mm for translations and positions, degrees for rotations (as the
//! `Trans A/B/C` entries of the kinematics table).
//!
//! The file holds one table per axis (`BEGIN X.COM MM` … `[END]`), preceded by a comment
//! preamble (lines starting with `;`) with the header sentences and the position errors
//! for the kinematics table (`; C0Y = +0.0000123456 deg`). Split it at the `BEGIN`
//! lines into X.COM, Y.COM, Z.COM for a controller.

use super::{Compensation, parse_not_identifiable, position_error_name, squareness_from};
use crate::FormatError;
use mtcal_solver::Axis;
use mtcal_solver::terms::Term;
use std::fmt::Write as _;

const DEG_PER_RAD: f64 = 180.0 / std::f64::consts::PI;

/// Column of `term` in its axis's COM table: C1…C6 in [`Term::all`] order of the axis.
fn column_name(term: Term) -> String {
    format!("C{}", term.index() % 6 + 1)
}

/// Writes `c` as KinematicsComp-style COM tables.
pub fn write(c: &Compensation) -> String {
    let mut s = c.header_comment(
        ";",
        "Heidenhain KinematicsComp-style COM tables (one per axis; split at BEGIN)",
        "translations and positions (ADDR) in mm, rotations in degrees",
        super::Format::Heidenhain.carries(),
    );
    for a in &c.axes {
        let cols: Vec<String> = a
            .columns
            .iter()
            .map(|col| {
                let t = Term::parse(&col.term).unwrap_or_else(|| unreachable!("a table term"));
                format!("{} = {}", column_name(t), col.term)
            })
            .collect();
        let _ = writeln!(s, "; {}.COM columns: {}", a.axis, cols.join(", "));
    }
    if !c.squareness.is_empty() {
        let _ = writeln!(
            s,
            "; position errors, for the kinematics table (COORD), degrees:"
        );
        for (n, v) in &c.squareness {
            let _ = writeln!(s, "; {} = {:+.12}", position_error_name(n), v * DEG_PER_RAD);
        }
    }
    for a in &c.axes {
        let _ = writeln!(s, "BEGIN {}.COM MM", a.axis);
        let _ = write!(s, "{:<6}{:>16}", "NR", "ADDR");
        for col in &a.columns {
            let t = Term::parse(&col.term).unwrap_or_else(|| unreachable!("a table term"));
            let _ = write!(s, "{:>18}", column_name(t));
        }
        s.push('\n');
        for (k, q) in a.positions_mm.iter().enumerate() {
            let _ = write!(s, "{k:<6}{q:>+16.6}");
            for col in &a.columns {
                let angular = Term::parse(&col.term).is_some_and(Term::is_angular);
                let v = col.values[k];
                if angular {
                    let _ = write!(s, "{:>+18.11}", v * DEG_PER_RAD);
                } else {
                    let _ = write!(s, "{v:>+18.9}");
                }
            }
            s.push('\n');
        }
        let _ = writeln!(s, "[END]");
    }
    s
}

/// Reads the file [`write`] makes: its COM tables and the position errors of its
/// preamble.
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    // The open table: its axis and columns (None until its header line).
    let mut table: Option<(Axis, Option<Vec<Option<Term>>>)> = None;
    let mut expected_nr = 0usize;
    for (i, raw) in text.lines().enumerate() {
        let n = (i + 1) as u64;
        let line = raw.trim();
        let err = |col: &str, rule: String| FormatError::new(name, n, col, rule);
        if line.is_empty() {
            continue;
        }
        if let Some(comment) = line.strip_prefix(';') {
            if table.is_some() {
                return Err(err("", "a comment inside a table".into()));
            }
            let comment = comment.trim();
            if let Some(list) = parse_not_identifiable(comment) {
                c.not_identifiable = list;
            } else if let Some(why) = comment.strip_prefix(super::FORCED) {
                c.forced = Some(why.to_string());
            } else if let Some((k, v)) = comment.split_once(" = ")
                && let Some(sq) = squareness_from(k.trim())
            {
                let deg = super::number(name, n as usize, k.trim(), v.trim())?;
                c.squareness.push((sq.to_string(), deg / DEG_PER_RAD));
            }
            continue;
        }
        match &mut table {
            None => {
                let f: Vec<&str> = line.split_whitespace().collect();
                let axis = match f.as_slice() {
                    ["BEGIN", file, "MM"] => file
                        .strip_suffix(".COM")
                        .and_then(super::axis_of)
                        .ok_or_else(|| {
                            err("", format!("`{file}`: expected X.COM, Y.COM or Z.COM"))
                        })?,
                    _ => return Err(err("", format!("`{line}`: expected `BEGIN X.COM MM`"))),
                };
                if c.axes.iter().any(|a| a.axis == axis) {
                    return Err(err("", format!("a second table of {axis}")));
                }
                table = Some((axis, None));
                expected_nr = 0;
            }
            Some((axis, cols @ None)) => {
                let f: Vec<&str> = line.split_whitespace().collect();
                if f.len() < 3 || f[0] != "NR" || f[1] != "ADDR" {
                    return Err(err("", format!("`{line}`: expected `NR ADDR C1 …`")));
                }
                let terms = f[2..]
                    .iter()
                    .map(|h| {
                        let k = h
                            .strip_prefix('C')
                            .and_then(|d| d.parse::<usize>().ok())
                            .filter(|k| (1..=6).contains(k))
                            .ok_or_else(|| err(h, format!("`{h}` is not a column C1 … C6")))?;
                        Ok(Some(Term::all()[6 * axis.index() + k - 1]))
                    })
                    .collect::<Result<Vec<_>, FormatError>>()?;
                *cols = Some(terms);
            }
            Some((axis, Some(cols))) => {
                if line == "[END]" {
                    if expected_nr == 0 {
                        return Err(err("", format!("the table of {axis} has no rows")));
                    }
                    table = None;
                    continue;
                }
                let f: Vec<&str> = line.split_whitespace().collect();
                if f.len() != cols.len() + 2 {
                    return Err(err(
                        "",
                        format!(
                            "{} fields where the header names {}",
                            f.len(),
                            cols.len() + 2
                        ),
                    ));
                }
                if f[0].parse::<usize>().ok() != Some(expected_nr) {
                    return Err(err(
                        "NR",
                        format!("`{}`: expected row number {expected_nr}", f[0]),
                    ));
                }
                expected_nr += 1;
                let q = super::number(name, n as usize, "ADDR", f[1])?;
                for (t, cell) in cols.iter().flatten().zip(&f[2..]) {
                    let col = column_name(*t);
                    let mut v = super::number(name, n as usize, &col, cell)?;
                    if t.is_angular() {
                        v /= DEG_PER_RAD;
                    }
                    super::push_point(&mut c.axes, *t, q, v).map_err(|rule| err(&col, rule))?;
                }
            }
        }
    }
    if let Some((axis, _)) = table {
        return Err(FormatError::new(
            name,
            text.lines().count() as u64,
            "",
            format!("the table of {axis} is not closed by [END]"),
        ));
    }
    super::finish(name, c)
}
