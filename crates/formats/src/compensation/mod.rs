//! Compensation tables from an identification result, for controllers that take 21-term
//! tables, and readers of the same files (for round trips and checks).
//!
//! A [`Compensation`] holds, per axis the check moved, the identifiable error functions
//! of that axis on a grid over its **measured travel** (every `step` mm from the start
//! of the travel, and its end: nothing is extrapolated), and the identifiable squareness
//! errors. Values are kept in the controllers' units: millimetres for translations,
//! radians for rotations, arguments in millimetres. Terms the data could not determine
//! are left out and listed.
//!
//! Sign convention (every file says it in its header comment): the values are the
//! machine's **errors** in the ISO 230-1 sense used by the result (tool relative to
//! workpiece, `docs/conventions.md`); a controller applies compensation = −error. The
//! values follow the result's reporting convention: straightness about its
//! least-squares line over the measured travel, squareness between the least-squares
//! axis lines (X–Y = 90° + EC0Y, X–Z = 90° − EB0Z, Y–Z = 90° + EA0Z).
//!
//! Formats (one module each, writer and reader):
//! * [`isg`]: ISG / Beckhoff TwinCAT CNC volumetric compensation, `ISG_CSV`;
//! * [`etalon`]: the Etalon exchange format ("Vendor" variant) as ISG reads it;
//! * [`heidenhain`]: a Heidenhain KinematicsComp-style `*.COM` table per axis;
//! * [`csv`]: a plain CSV with ISO 230-1 names, in µm and µrad, with forward and reverse
//!   values where a reversal was found and the thermal coefficients per kelvin;
//! * [`linuxcnc`]: LinuxCNC's joint compensation file (`COMP_FILE_TYPE = 0`): nominal,
//!   forward and reverse positions of each axis along itself.
//!
//! The physics a diagnosis found (reversal, thermal coefficients) comes in through
//! [`physics`].
//!
//! The values come from [`IdentificationResult::reported_value_at`]: the solver's own
//! evaluation of a result's terms.

pub mod csv;
pub mod etalon;
pub mod heidenhain;
pub mod isg;
pub mod linuxcnc;
pub mod physics;

use crate::FormatError;
use mtcal_solver::Axis;
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::terms::{SquarenessTerm, Term, TermKind};
pub use physics::{Carries, Thermal, ThermalKind};

/// Default spacing of the table's arguments, mm.
pub const DEFAULT_STEP_MM: f64 = 5.0;
/// Most grid points per axis (a controller's table is bounded; so is the file).
pub const MAX_POINTS_PER_AXIS: usize = 20_000;
/// Largest file a reader accepts, bytes.
pub const MAX_FILE_BYTES: usize = 32 << 20;

/// The export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    Isg,
    Etalon,
    Heidenhain,
    Csv,
    Linuxcnc,
}

impl Format {
    pub const ALL: [Format; 5] = [
        Format::Isg,
        Format::Etalon,
        Format::Heidenhain,
        Format::Csv,
        Format::Linuxcnc,
    ];

    /// Name on the command line and in the API (`format=`).
    pub fn name(self) -> &'static str {
        match self {
            Format::Isg => "isg",
            Format::Etalon => "etalon",
            Format::Heidenhain => "heidenhain",
            Format::Csv => "csv",
            Format::Linuxcnc => "linuxcnc",
        }
    }

    /// What the format holds besides the geometric errors.
    pub fn carries(self) -> Carries {
        Carries {
            reversal: matches!(self, Format::Csv | Format::Linuxcnc),
            thermal: self == Format::Csv,
        }
    }

    /// Whether the format holds every identifiable term (LinuxCNC holds each axis's
    /// error along itself only).
    pub fn holds_every_term(self) -> bool {
        self != Format::Linuxcnc
    }

    /// Whether `c` fits this format: LinuxCNC takes at most
    /// [`linuxcnc::MAX_TRIPLETS`] triplets per joint and needs an axis with a positioning
    /// error or a reversal.
    pub fn check(self, c: &Compensation) -> Result<(), ExportError> {
        if self == Format::Linuxcnc {
            linuxcnc::check(c)?;
        }
        Ok(())
    }

    /// The format named `s`; the error names the formats.
    pub fn parse(s: &str) -> Result<Format, String> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| {
                format!(
                    "unknown export format `{s}`: use one of {}",
                    Format::names()
                )
            })
    }

    /// `isg, etalon, heidenhain, csv, linuxcnc`.
    pub fn names() -> String {
        Format::ALL.map(Format::name).join(", ")
    }

    /// Media type of the file.
    pub fn content_type(self) -> &'static str {
        match self {
            Format::Csv => "text/csv; charset=utf-8",
            _ => "text/plain; charset=utf-8",
        }
    }

    /// File name extension.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Isg | Format::Csv => "csv",
            Format::Etalon | Format::Linuxcnc => "txt",
            Format::Heidenhain => "com",
        }
    }

    /// Writes `c` in this format.
    pub fn write(self, c: &Compensation) -> String {
        match self {
            Format::Isg => isg::write(c),
            Format::Etalon => etalon::write(c),
            Format::Heidenhain => heidenhain::write(c),
            Format::Csv => csv::write(c),
            Format::Linuxcnc => linuxcnc::write(c),
        }
    }

    /// Reads a file of this format named `name`.
    pub fn read(self, name: &str, text: &str) -> Result<Compensation, FormatError> {
        if text.len() > MAX_FILE_BYTES {
            return Err(
                FormatError::file(name, format!("file exceeds {MAX_FILE_BYTES} bytes")).as_limit(),
            );
        }
        match self {
            Format::Isg => isg::read(name, text),
            Format::Etalon => etalon::read(name, text),
            Format::Heidenhain => heidenhain::read(name, text),
            Format::Csv => csv::read(name, text),
            Format::Linuxcnc => linuxcnc::read(name, text),
        }
    }
}

/// One error function on the axis grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// ISO 230-1 name, e.g. `EYX`.
    pub term: String,
    /// Error at each grid position: mm (translation) or rad (rotation).
    pub values: Vec<f64>,
}

/// The identifiable error functions of one axis over its measured travel.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisTable {
    pub axis: Axis,
    /// Grid positions (the argument), mm, increasing, inside the measured travel.
    pub positions_mm: Vec<f64>,
    /// In [`Term::all`] order: EXX EYX EZX EAX EBX ECX for X.
    pub columns: Vec<Column>,
    /// The lost motion b at each position, mm ([`physics`]: error forward −b/2, reverse
    /// +b/2), where a reversal was found.
    pub reversal_mm: Option<Vec<f64>>,
}

impl AxisTable {
    /// The column of the axis's error along itself (EXX of X), when identifiable.
    pub fn positioning(&self) -> Option<&Column> {
        self.columns
            .iter()
            .find(|c| Term::parse(&c.term).is_some_and(|t| t.kind() == TermKind::Positioning))
    }
}

/// A compensation table (values in mm and rad).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Compensation {
    /// Machine and measurement time (header only; empty when read from a file that lacks
    /// them).
    pub machine_id: String,
    pub measured_at: String,
    pub axes: Vec<AxisTable>,
    /// Identifiable squareness errors: (`EC0Y` | `EB0Z` | `EA0Z`, rad).
    pub squareness: Vec<(String, f64)>,
    /// Terms left out because the data could not determine them (ISO 230-1 names).
    pub not_identifiable: Vec<String>,
    /// Set when the table was made although the model does not explain its recording
    /// (forced): the reason, written in the header's [`FORCED`] line.
    pub forced: Option<String>,
    /// Set when the result is decided on the explained model (the 21 terms fitted jointly
    /// with the physics a diagnosis found): the gate's statement, written in the header's
    /// [`EXPLAINED`] line (not read back).
    pub explained: Option<String>,
    /// Thermal coefficients per kelvin the diagnosis found ([`physics`]).
    pub thermal: Vec<Thermal>,
}

/// Why a result gives no table.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExportError {
    #[error("{0}")]
    BadStep(String),
    /// Not one term of the result is identifiable over a measured travel.
    #[error("nothing to export: no term of this result is identifiable ({0})")]
    NothingIdentifiable(String),
    /// The model does not explain its recording (the misfit gate): a table of it would
    /// compensate errors the machine may not have; refused unless forced.
    #[error(
        "{0}: no compensation table is made from it unless forced (--force, or force=true); the diagnosis of the recording says which physics the model leaves out"
    )]
    ModelMisfit(String),
}

impl Compensation {
    /// The table of `r` on every `step_mm` of each axis's measured travel (and its end).
    /// A result whose model does not explain its recording ([`mtcal_solver::misfit`]) is
    /// refused ([`ExportError::ModelMisfit`]) unless `force`; a forced table says why in
    /// its header ([`FORCED`]).
    pub fn from_result(
        r: &IdentificationResult,
        step_mm: f64,
        force: bool,
    ) -> Result<Compensation, ExportError> {
        let min = mtcal_solver::comparison::MIN_STEP_MM;
        if !step_mm.is_finite() || step_mm < min {
            return Err(ExportError::BadStep(format!(
                "step must be a number of mm of at least {min}, got {step_mm}"
            )));
        }
        let check = r.model_check();
        let explained = check
            .decided_on_explained_model()
            .then(|| check.statement.clone());
        let forced = match (check.is_misfit(), force) {
            (true, false) => return Err(ExportError::ModelMisfit(check.statement)),
            (true, true) => Some(check.statement),
            (false, _) => None,
        };
        let mut c = Compensation {
            machine_id: r.machine_id.clone(),
            measured_at: r.measured_at.clone(),
            forced,
            explained,
            ..Default::default()
        };
        for axis in Axis::ALL {
            let terms = Term::all().into_iter().filter(|t| t.axis == axis);
            let Some(&[lo, hi]) = r.model.measured_travel_mm.get(&axis.letter().to_string()) else {
                c.not_identifiable.extend(terms.map(Term::name));
                continue;
            };
            let positions = grid(lo, hi, step_mm).ok_or_else(|| {
                ExportError::BadStep(format!(
                    "a step of {step_mm} mm over the measured travel of {axis} [{lo}, {hi}] mm \
                     gives more than {MAX_POINTS_PER_AXIS} points"
                ))
            })?;
            let mut columns = Vec::new();
            for t in terms {
                let (name, scale) = (t.code(), unit_scale(t));
                let values: Option<Vec<f64>> = positions
                    .iter()
                    // `+ 0.0` turns a −0 into 0 (no `-0.000` in a file).
                    .map(|&q| r.reported_value_at(name, q).map(|v| v * scale + 0.0))
                    .collect();
                match values {
                    Some(values) => columns.push(Column {
                        term: name.to_string(),
                        values,
                    }),
                    None => c.not_identifiable.push(name.to_string()),
                }
            }
            if !columns.is_empty() {
                c.axes.push(AxisTable {
                    axis,
                    positions_mm: positions,
                    columns,
                    reversal_mm: None,
                });
            }
        }
        for s in SquarenessTerm::ALL {
            match r.squareness.get(s.name()) {
                Some(rep) if rep.identifiable && rep.value_urad.is_some() => c
                    .squareness
                    .push((s.name().to_string(), rep.value_urad.unwrap_or(0.0) * 1e-6)),
                _ => c.not_identifiable.push(s.name().to_string()),
            }
        }
        if c.axes.is_empty() && c.squareness.is_empty() {
            return Err(ExportError::NothingIdentifiable(format!(
                "not identifiable: {}",
                c.not_identifiable.join(", ")
            )));
        }
        Ok(c)
    }

    /// The header comment every file opens with: [`Compensation::header`], each line
    /// after `prefix` and a blank.
    pub fn header_comment(
        &self,
        prefix: &str,
        format: &str,
        units: &str,
        carries: Carries,
    ) -> String {
        self.header(format, units, carries)
            .into_iter()
            .map(|h| format!("{prefix} {h}\n"))
            .collect()
    }

    /// The sentences every file's header comment carries (each format adds its prefix),
    /// with what the format `carries` of the physics found.
    pub fn header(&self, format: &str, units: &str, carries: Carries) -> Vec<String> {
        let mut h = vec![];
        if let Some(why) = &self.forced {
            h.push(format!("{FORCED}{why}"));
        }
        h.extend([
            format!("mtcal compensation table: {format}"),
            format!(
                "machine: {}; measured at: {}",
                self.machine_id, self.measured_at
            ),
        ]);
        if let Some(why) = &self.explained {
            h.push(format!("{EXPLAINED}{why}"));
        }
        h.extend([
            "sign: the values are the machine's errors (ISO 230-1, tool relative to workpiece); \
             compensation = -error"
                .into(),
            format!("units: {units}"),
            "straightness: deviation from its least-squares line over the measured travel; \
             squareness: angle between the least-squares axis lines \
             (X-Y = 90 deg + EC0Y, X-Z = 90 deg - EB0Z, Y-Z = 90 deg + EA0Z)"
                .into(),
        ]);
        let travel: Vec<String> = self
            .axes
            .iter()
            .filter_map(|a| {
                Some(format!(
                    "{} [{}, {}] mm",
                    a.axis,
                    a.positions_mm.first()?,
                    a.positions_mm.last()?
                ))
            })
            .collect();
        h.push(format!(
            "measured travel (the table covers it and nothing else): {}",
            travel.join("; ")
        ));
        h.push(format!(
            "{NOT_IDENTIFIABLE}{}",
            if self.not_identifiable.is_empty() {
                "none".to_string()
            } else {
                self.not_identifiable.join(", ")
            }
        ));
        h.extend(self.physics_header(carries));
        h
    }
}

/// Start of the header line of a table of a result decided on the explained model.
pub const EXPLAINED: &str = "model: ";

/// Start of the header line that lists the terms left out (readers look for it).
pub const NOT_IDENTIFIABLE: &str = "not identifiable, left out: ";

/// Start of the first header line of a table made although its model does not explain
/// the recording (readers look for it).
pub const FORCED: &str = "FORCED, NOT FOR USE WITHOUT REVIEW: ";

/// From the result's units (µm, µrad) to the table's (mm, rad).
fn unit_scale(t: Term) -> f64 {
    if t.is_angular() { 1e-6 } else { 1e-3 }
}

/// lo, lo + step, …, and hi (when the steps do not land on it); `None` past
/// [`MAX_POINTS_PER_AXIS`].
fn grid(lo: f64, hi: f64, step: f64) -> Option<Vec<f64>> {
    let n = ((hi - lo) / step).floor();
    if !(n.is_finite() && n >= 0.0 && n < MAX_POINTS_PER_AXIS as f64) {
        return None;
    }
    let mut g: Vec<f64> = (0..=n as usize).map(|k| lo + k as f64 * step).collect();
    if hi - g[g.len() - 1] > 1e-9 * step.max(1.0) {
        g.push(hi);
    }
    Some(g)
}

/// Whether `line` is a comment (starts with `prefix`); a [`NOT_IDENTIFIABLE`] comment
/// sets `c.not_identifiable`.
fn comment(c: &mut Compensation, line: &str, prefix: &str) -> bool {
    let Some(text) = line.trim().strip_prefix(prefix) else {
        return false;
    };
    if let Some(list) = parse_not_identifiable(text) {
        c.not_identifiable = list;
    }
    if let Some(why) = text.trim().strip_prefix(FORCED) {
        c.forced = Some(why.to_string());
    }
    true
}

/// The list of a [`NOT_IDENTIFIABLE`] header line (after the comment prefix).
fn parse_not_identifiable(line: &str) -> Option<Vec<String>> {
    let rest = line.trim().strip_prefix(NOT_IDENTIFIABLE)?;
    Some(if rest.trim() == "none" {
        vec![]
    } else {
        rest.split(',').map(|s| s.trim().to_string()).collect()
    })
}

/// ISG and Etalon name a squareness (position error) without the E: `C0Y`.
fn position_error_name(sq: &str) -> &str {
    &sq[1..]
}

/// The squareness named `C0Y` / `B0Z` / `A0Z` (or with the E), as `EC0Y` etc.
fn squareness_from(name: &str) -> Option<&'static str> {
    SquarenessTerm::ALL
        .into_iter()
        .map(SquarenessTerm::name)
        .find(|s| *s == name || &s[1..] == name)
}

/// A number cell; the error names file, line, column and rule.
fn number(file: &str, line: usize, column: &str, cell: &str) -> Result<f64, FormatError> {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(FormatError::new(
            file,
            line as u64,
            column,
            format!("`{cell}` is not a finite number"),
        )),
    }
}

/// Adds `(position, value)` of `term` to `axes` (creating the axis table or column):
/// readers of formats that list a term at a time use it. Positions of the terms of one
/// axis must agree.
fn push_point(axes: &mut Vec<AxisTable>, term: Term, q: f64, v: f64) -> Result<(), String> {
    let i = match axes.iter().position(|a| a.axis == term.axis) {
        Some(i) => i,
        None => {
            axes.push(AxisTable {
                axis: term.axis,
                positions_mm: vec![],
                columns: vec![],
                reversal_mm: None,
            });
            axes.len() - 1
        }
    };
    let a = &mut axes[i];
    let ci = match a.columns.iter().position(|c| c.term == term.code()) {
        Some(ci) => ci,
        None => {
            a.columns.push(Column {
                term: term.code().to_string(),
                values: vec![],
            });
            a.columns.len() - 1
        }
    };
    let k = a.columns[ci].values.len();
    if ci == 0 {
        if a.positions_mm.last().is_some_and(|&p| q <= p) {
            return Err(format!("position {q} mm does not increase"));
        }
        a.positions_mm.push(q);
    } else if a.positions_mm.get(k).is_none_or(|&p| (p - q).abs() > 1e-6) {
        return Err(format!(
            "{} at {q} mm: the terms of axis {} must share the positions of {}",
            term.code(),
            term.axis,
            a.columns[0].term
        ));
    }
    a.columns[ci].values.push(v);
    Ok(())
}

/// Checks that every column of every axis has a value at each position and sorts axes
/// and columns into [`Term::all`] order.
fn finish(file: &str, mut c: Compensation) -> Result<Compensation, FormatError> {
    for a in &mut c.axes {
        if let Some(b) = &a.reversal_mm
            && b.len() != a.positions_mm.len()
        {
            return Err(FormatError::new(
                file,
                0,
                "error_forward",
                format!(
                    "{} reversal values for {} positions of {}",
                    b.len(),
                    a.positions_mm.len(),
                    a.axis
                ),
            ));
        }
        for col in &a.columns {
            if col.values.len() != a.positions_mm.len() {
                return Err(FormatError::new(
                    file,
                    0,
                    col.term.as_str(),
                    format!(
                        "{} has {} values for {} positions of {}",
                        col.term,
                        col.values.len(),
                        a.positions_mm.len(),
                        a.axis
                    ),
                ));
            }
        }
        a.columns
            .sort_by_key(|col| Term::parse(&col.term).map_or(usize::MAX, Term::index));
    }
    c.axes.sort_by_key(|a| a.axis.index());
    c.squareness.sort_by_key(|(n, _)| {
        SquarenessTerm::ALL
            .iter()
            .position(|s| s.name() == n)
            .unwrap_or(usize::MAX)
    });
    if c.axes.is_empty() && c.squareness.is_empty() {
        return Err(FormatError::file(file, "no error values in the file"));
    }
    Ok(c)
}

/// The axis letter `X`, `Y` or `Z`.
fn axis_of(s: &str) -> Option<Axis> {
    match s {
        "X" => Some(Axis::X),
        "Y" => Some(Axis::Y),
        "Z" => Some(Axis::Z),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_starts_at_the_travel_and_ends_on_it() {
        assert_eq!(
            grid(-10.0, 10.0, 5.0).unwrap(),
            [-10.0, -5.0, 0.0, 5.0, 10.0]
        );
        assert_eq!(grid(-7.5, 4.0, 5.0).unwrap(), [-7.5, -2.5, 2.5, 4.0]);
        assert_eq!(grid(0.0, 1e9, 1.0), None);
        assert_eq!(Format::parse("isg"), Ok(Format::Isg));
        let e = Format::parse("fanuc").unwrap_err();
        assert!(e.contains("isg, etalon, heidenhain, csv, linuxcnc"), "{e}");
    }
}
