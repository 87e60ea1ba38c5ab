//! The Etalon exchange format ("Vendor" variant), as ISG's volumetric compensation
//! reads it.
//!
//! Layout as published by ISG (ISG kernel documentation, "Etalon Exchange Format"): an
//! INI-like file, row comments start with `//`; each parameter is a block beginning with
//! its name in square brackets; a position error (squareness) holds `VALUE = v`
//! (`[C0Y]`); a component error holds a two-column lookup table `Gridpoints = { … }`,
//! one record `argument value` per line, closed by `}` (the published example ends it
//! with `// end of EXY`). Units as in ISG CSV: mm and rad, arguments in mm.

use super::{Compensation, position_error_name, squareness_from};
use crate::FormatError;
use mtcal_solver::terms::Term;
use std::fmt::Write as _;

/// Writes `c` in the Etalon exchange format.
pub fn write(c: &Compensation) -> String {
    let mut s = c.header_comment(
        "//",
        "Etalon exchange format (Vendor variant)",
        "errors in mm and rad, arguments in mm",
        super::Format::Etalon.carries(),
    );
    for (n, v) in &c.squareness {
        let _ = writeln!(s, "[{}]\nVALUE = {v:.12}", position_error_name(n));
    }
    for a in &c.axes {
        for col in &a.columns {
            let angular = Term::parse(&col.term).is_some_and(Term::is_angular);
            let _ = writeln!(s, "[{}]\nGridpoints = {{", col.term);
            for (q, v) in a.positions_mm.iter().zip(&col.values) {
                if angular {
                    let _ = writeln!(s, "{q:.6} {v:.12}");
                } else {
                    let _ = writeln!(s, "{q:.6} {v:.9}");
                }
            }
            let _ = writeln!(s, "}}  // end of {}", col.term);
        }
    }
    s
}

/// Reads an Etalon exchange file with the component errors of X, Y, Z and the position
/// errors C0Y, B0Z, A0Z.
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    // The open block: its name, and whether a Gridpoints table is open.
    let mut block: Option<(String, bool)> = None;
    for (i, raw) in text.lines().enumerate() {
        let n = (i + 1) as u64;
        super::comment(&mut c, raw, "//");
        let line = raw.split("//").next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let err = |col: &str, rule: String| FormatError::new(name, n, col, rule);
        match &mut block {
            Some((term, true)) => {
                if line == "}" {
                    block = None;
                    continue;
                }
                let f: Vec<&str> = line.split_whitespace().collect();
                if f.len() != 2 {
                    return Err(err(
                        term,
                        format!("`{line}`: a grid point is `argument value`"),
                    ));
                }
                let q = super::number(name, n as usize, term, f[0])?;
                let v = super::number(name, n as usize, term, f[1])?;
                let t = Term::parse(term).unwrap_or_else(|| unreachable!("checked at the block"));
                super::push_point(&mut c.axes, t, q, v).map_err(|rule| err(term, rule))?;
            }
            _ => {
                if let Some(inner) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
                    if squareness_from(inner).is_none() && Term::parse(inner).is_none() {
                        return Err(err(
                            inner,
                            format!(
                                "`[{inner}]` is not a component error of X, Y, Z or C0Y, B0Z, A0Z"
                            ),
                        ));
                    }
                    block = Some((inner.to_string(), false));
                    continue;
                }
                let Some((key, rest)) = line.split_once('=') else {
                    return Err(err(
                        "",
                        format!("`{line}`: expected `[NAME]`, `VALUE = …` or `Gridpoints = {{`"),
                    ));
                };
                let Some((term, _)) = &block else {
                    return Err(err(key.trim(), "outside a [NAME] block".into()));
                };
                let term = term.clone();
                match (key.trim(), squareness_from(&term)) {
                    ("VALUE", Some(sq)) => {
                        if c.squareness.iter().any(|(s, _)| s == sq) {
                            return Err(err(&term, "given twice".into()));
                        }
                        let v = super::number(name, n as usize, &term, rest.trim())?;
                        c.squareness.push((sq.to_string(), v));
                        block = None;
                    }
                    ("Gridpoints", None) if rest.trim() == "{" => {
                        if c.axes
                            .iter()
                            .flat_map(|a| &a.columns)
                            .any(|col| col.term == term)
                        {
                            return Err(err(&term, "given twice".into()));
                        }
                        block = Some((term, true));
                    }
                    (k, _) => {
                        return Err(err(
                            &term,
                            format!(
                                "`{k}` in [{term}]: a position error takes `VALUE = v`, a component error `Gridpoints = {{`"
                            ),
                        ));
                    }
                }
            }
        }
    }
    if let Some((term, true)) = block {
        return Err(FormatError::new(
            name,
            text.lines().count() as u64,
            term.as_str(),
            "Gridpoints not closed by `}`",
        ));
    }
    super::finish(name, c)
}
