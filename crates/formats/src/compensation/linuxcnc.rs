//! LinuxCNC's joint compensation file (`[JOINT_n] COMP_FILE` with `COMP_FILE_TYPE = 0`).
//!
//! Layout as LinuxCNC documents it (INI configuration manual, `[JOINT_n]` section): one
//! triplet per line, blank-separated, in machine units; the first value is the nominal
//! (commanded) position, the second the actual position while the joint moves in the
//! positive direction, the third while it moves in the negative direction; nominal
//! positions ascending; at most 256 triplets per joint; `BACKLASH` is not used when a
//! `COMP_FILE` is given. LinuxCNC's loader reads triplets up to the first line that is
//! not one, so the file opens with data (a forced table opens with its `FORCED` line,
//! so that LinuxCNC loads nothing of it until the line is removed after review).
//!
//! mtcal writes, for each axis with an error along itself (EXX of X) or a reversal, the
//! triplets `q  q + e(q) − b(q)/2  q + e(q) + b(q)/2` in mm (e the axis's error along
//! itself, b its lost motion, [`super::physics`]), then the line `# end of X …` naming the
//! axis, its joint under trivkins (X = 0, Y = 1, Z = 2) and its columns; after the last
//! axis, the header comment. Split the file after each `# end of` line: each part is
//! one joint's `COMP_FILE`. A machine in inches: divide every value by 25.4.
//!
//! ```text
//! -200.000000 -200.001250 -199.995290
//! …
//! # end of X (JOINT_0 COMP_FILE, COMP_FILE_TYPE = 0): EXX and reversal
//! # mtcal compensation table: …
//! ```

use super::{AxisTable, Column, Compensation, ExportError};
use crate::FormatError;
use mtcal_solver::Axis;
use mtcal_solver::terms::{Component, Term};
use std::fmt::Write as _;

/// Most triplets LinuxCNC takes per joint.
pub const MAX_TRIPLETS: usize = 256;

/// Start of the line after each axis's triplets.
pub const END: &str = "# end of ";

/// The axes the file holds: those with an error along itself or a reversal.
fn written(c: &Compensation) -> impl Iterator<Item = &AxisTable> {
    c.axes
        .iter()
        .filter(|a| a.positioning().is_some() || a.reversal_mm.is_some())
}

/// Whether `c` fits a LinuxCNC file ([`MAX_TRIPLETS`], something to write).
pub fn check(c: &Compensation) -> Result<(), ExportError> {
    if written(c).next().is_none() {
        return Err(ExportError::NothingIdentifiable(
            "linuxcnc: no axis has an identifiable error along itself (EXX, EYY, EZZ) or a \
             reversal"
                .into(),
        ));
    }
    for a in written(c) {
        if a.positions_mm.len() > MAX_TRIPLETS {
            return Err(ExportError::BadStep(format!(
                "LinuxCNC takes at most {MAX_TRIPLETS} triplets per joint; {} has {} at this \
                 step: use a larger step",
                a.axis,
                a.positions_mm.len()
            )));
        }
    }
    Ok(())
}

/// Writes `c` as LinuxCNC compensation triplets (module docs).
pub fn write(c: &Compensation) -> String {
    let mut s = String::new();
    // A forced table opens with its FORCED line: LinuxCNC reads no triplet while it is
    // there (its loader stops at the first line that is not one), so the table is loaded
    // only once someone has reviewed it and removed the line.
    if let Some(why) = &c.forced {
        let _ = writeln!(s, "# {}{why}", super::FORCED);
    }
    for a in written(c) {
        let e = a.positioning();
        for (k, q) in a.positions_mm.iter().enumerate() {
            let err = e.map_or(0.0, |col| col.values[k]);
            let half = a.reversal_mm.as_ref().map_or(0.0, |b| b[k] * 0.5);
            let _ = writeln!(
                s,
                "{q:.6} {:.6} {:.6}",
                q + err - half + 0.0,
                q + err + half + 0.0
            );
        }
        let what = match (e, &a.reversal_mm) {
            (Some(col), Some(_)) => format!("{} and reversal", col.term),
            (Some(col), None) => format!("{} (no reversal found)", col.term),
            (None, _) => "reversal only (its error along itself is not identifiable)".into(),
        };
        let _ = writeln!(
            s,
            "{END}{} (JOINT_{} COMP_FILE, COMP_FILE_TYPE = 0): {what}",
            a.axis,
            a.axis.index()
        );
    }
    s.push_str(&c.header_comment(
        "#",
        "LinuxCNC joint compensation (COMP_FILE_TYPE = 0: nominal, forward, reverse)",
        "machine units mm (for a machine in inches divide by 25.4); nominal = commanded \
         position; forward / reverse = the actual position travelling toward + / toward -; \
         only each axis's error along itself and its reversal (the other terms: formats isg, \
         etalon, heidenhain, csv)",
        super::Format::Linuxcnc.carries(),
    ));
    s
}

/// Reads the file [`write`] makes: each axis's error along itself (the mean of forward
/// and reverse, less the nominal) and its reversal (reverse − forward).
pub fn read(name: &str, text: &str) -> Result<Compensation, FormatError> {
    let mut c = Compensation::default();
    let mut block: Vec<(u64, [f64; 3])> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let n = (i + 1) as u64;
        let line = raw.trim();
        if let Some(rest) = line.strip_prefix(END) {
            let axis = rest
                .split_whitespace()
                .next()
                .and_then(super::axis_of)
                .ok_or_else(|| FormatError::new(name, n, "", "`# end of` names X, Y or Z"))?;
            let own = !rest.contains("reversal only");
            let mut t = table(name, n, axis, own, &block)?;
            if rest.contains("no reversal found") {
                t.reversal_mm = None;
            }
            c.axes.push(t);
            block.clear();
            continue;
        }
        if super::comment(&mut c, line, "#") || line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != 3 {
            return Err(FormatError::new(
                name,
                n,
                "",
                format!("{} fields: a line is a triplet", f.len()),
            ));
        }
        let mut v = [0.0; 3];
        for (k, col) in ["nominal", "forward", "reverse"].into_iter().enumerate() {
            v[k] = super::number(name, n as usize, col, f[k])?;
        }
        if block.last().is_some_and(|(_, p)| v[0] <= p[0]) {
            return Err(FormatError::new(
                name,
                n,
                "nominal",
                "nominal positions must ascend",
            ));
        }
        block.push((n, v));
    }
    if let Some((n, _)) = block.first() {
        return Err(FormatError::new(
            name,
            *n,
            "",
            "triplets without an `# end of` line naming their axis",
        ));
    }
    super::finish(name, c)
}

/// The table of `axis` from its triplets; `own`: the file holds its error along itself.
fn table(
    name: &str,
    n: u64,
    axis: Axis,
    own: bool,
    block: &[(u64, [f64; 3])],
) -> Result<AxisTable, FormatError> {
    if block.is_empty() {
        return Err(FormatError::new(
            name,
            n,
            "",
            format!("no triplets for {axis}"),
        ));
    }
    if block.len() > MAX_TRIPLETS {
        return Err(FormatError::new(
            name,
            n,
            "",
            format!(
                "{} triplets for {axis}: LinuxCNC takes at most {MAX_TRIPLETS}",
                block.len()
            ),
        ));
    }
    let term = Term {
        axis,
        component: Component::Translation(axis),
    };
    let columns = if own {
        vec![Column {
            term: term.code().to_string(),
            values: block
                .iter()
                .map(|(_, [q, f, r])| 0.5 * (f + r) - q)
                .collect(),
        }]
    } else {
        vec![]
    };
    Ok(AxisTable {
        axis,
        positions_mm: block.iter().map(|(_, v)| v[0]).collect(),
        columns,
        reversal_mm: Some(block.iter().map(|(_, [_, f, r])| r - f).collect()),
    })
}
