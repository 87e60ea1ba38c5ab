//! Size limits applied while reading (datasets contract, "Rules for every format":
//! limits are configurable; defaults 5 million samples per file, 256 MiB per upload), and
//! plausibility bounds on magnitudes: a finite but absurd value (a deviation of 1e308 µm,
//! a position in µm where mm are required) is refused at the cell that holds it, naming
//! the file, line and column, instead of reaching the solver. Columns per header and
//! bytes per line are capped too, and a caller may set a deadline, so that no input makes
//! a read run long: every reader's work is linear in its input and bounded in time.

use crate::FormatError;
use std::time::Instant;

/// Largest length of a file name in an upload (and of an archive entry's path shown in a
/// message).
pub const MAX_NAME_LEN: usize = 200;

/// Limits applied by every reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest number of data rows (samples) accepted in one CSV file.
    pub max_samples_per_file: usize,
    /// Largest number of bytes accepted in one upload (one call of a reader), counted
    /// both as stored and after gzip decompression, summed over all files of the upload.
    pub max_bytes: usize,
    /// Largest number of files in one upload or archive (folders: files read).
    pub max_files: usize,
    /// Largest |deviation| accepted, µm (plane files' du/dv, positioning deviations).
    pub max_abs_deviation_um: f64,
    /// Largest |position| accepted, mm (axis positions, targets, point coordinates).
    pub max_abs_position_mm: f64,
    /// Largest |time| accepted, s (sample and log times).
    pub max_abs_time_s: f64,
    /// Largest |temperature| accepted, °C.
    pub max_abs_temperature_c: f64,
    /// Largest |angle| accepted, degrees (rotary axes' commanded angles).
    pub max_abs_angle_deg: f64,
    /// Largest |value| of any other numeric column (drift-log channels).
    pub max_abs_value: f64,
    /// Largest number of columns in a CSV header (a drift log's channels included).
    pub max_columns: usize,
    /// Largest length of one CSV record (a line, or several when a quoted field holds
    /// line breaks), bytes, separators counted.
    pub max_line_bytes: usize,
    /// When set, reading stops with a limit error once this instant has passed (checked
    /// per file and every [`Limits::DEADLINE_CHECK_ROWS`] rows): the service sets it per
    /// upload so that no upload holds a parsing thread past its request's time limit.
    pub deadline: Option<Instant>,
    /// How the CSV files are written (not a limit: carried here because every reader
    /// takes its settings from `Limits`). [`CsvDialect::Plain`] by default; a file in
    /// the other dialect is refused with what to change.
    pub csv_dialect: CsvDialect,
}

/// How a CSV file is written (`docs/datasets.md`, "Spreadsheet (Excel) CSV").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CsvDialect {
    /// The datasets format: `,` separators, `.` decimal points.
    #[default]
    Plain,
    /// What a spreadsheet saves as CSV in a locale with decimal commas: `;` separators and
    /// `,` decimal points (a `.` is read too), often with a UTF-8 byte-order mark.
    Excel,
}

impl CsvDialect {
    /// `plain` or `excel`.
    pub fn parse(s: &str) -> Option<CsvDialect> {
        match s.trim().to_ascii_lowercase().as_str() {
            "plain" => Some(CsvDialect::Plain),
            "excel" => Some(CsvDialect::Excel),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            CsvDialect::Plain => "plain",
            CsvDialect::Excel => "excel",
        }
    }

    /// The field separator.
    pub fn delimiter(self) -> u8 {
        match self {
            CsvDialect::Plain => b',',
            CsvDialect::Excel => b';',
        }
    }
}

impl Limits {
    pub const DEFAULT_MAX_SAMPLES_PER_FILE: usize = 5_000_000;
    pub const DEFAULT_MAX_BYTES: usize = 256 * 1024 * 1024;
    pub const DEFAULT_MAX_FILES: usize = 1000;
    /// 10 mm: a grid encoder reads ±1 mm at most; a larger deviation is a unit mistake.
    pub const DEFAULT_MAX_ABS_DEVIATION_UM: f64 = 10_000.0;
    /// 100 m, the longest machine travel the service accepts.
    pub const DEFAULT_MAX_ABS_POSITION_MM: f64 = 100_000.0;
    /// About three years.
    pub const DEFAULT_MAX_ABS_TIME_S: f64 = 1e8;
    pub const DEFAULT_MAX_ABS_TEMPERATURE_C: f64 = 1000.0;
    /// 100 turns.
    pub const DEFAULT_MAX_ABS_ANGLE_DEG: f64 = 36_000.0;
    pub const DEFAULT_MAX_ABS_VALUE: f64 = 1e9;
    /// A plane file has 9 columns; a drift log of a thousand channels still fits.
    pub const DEFAULT_MAX_COLUMNS: usize = 1024;
    /// 64 KiB: a data line is about 100 bytes, a 1024-channel drift-log line about 20 KB.
    pub const DEFAULT_MAX_LINE_BYTES: usize = 64 * 1024;
    /// Rows read between two looks at the clock.
    pub const DEADLINE_CHECK_ROWS: usize = 4096;

    /// These limits reading CSV files in `dialect`.
    pub fn with_dialect(self, dialect: CsvDialect) -> Limits {
        Limits {
            csv_dialect: dialect,
            ..self
        }
    }

    /// These limits with a deadline `after` from now.
    pub fn with_time_limit(self, after: std::time::Duration) -> Limits {
        Limits {
            deadline: Instant::now().checked_add(after),
            ..self
        }
    }

    /// A limit error about `file` (at `line`, 0 when none) once the deadline has passed.
    pub fn check_deadline(&self, file: &str, line: u64) -> Result<(), FormatError> {
        self.check_deadline_at(file, || line)
    }

    /// [`Limits::check_deadline`] with the line computed only when the deadline has
    /// passed (a CSV line number is a count of the newlines before it: paid once, for
    /// the error, not at every look at the clock).
    pub(crate) fn check_deadline_at(
        &self,
        file: &str,
        line: impl FnOnce() -> u64,
    ) -> Result<(), FormatError> {
        match self.deadline {
            Some(d) if Instant::now() >= d => Err(FormatError::new(
                file,
                line(),
                "",
                "reading stopped: the time allowed to read this upload ran out (the \
                 service's upload time limit)",
            )
            .as_limit()),
            _ => Ok(()),
        }
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_samples_per_file: Self::DEFAULT_MAX_SAMPLES_PER_FILE,
            max_bytes: Self::DEFAULT_MAX_BYTES,
            max_files: Self::DEFAULT_MAX_FILES,
            max_abs_deviation_um: Self::DEFAULT_MAX_ABS_DEVIATION_UM,
            max_abs_position_mm: Self::DEFAULT_MAX_ABS_POSITION_MM,
            max_abs_time_s: Self::DEFAULT_MAX_ABS_TIME_S,
            max_abs_temperature_c: Self::DEFAULT_MAX_ABS_TEMPERATURE_C,
            max_abs_angle_deg: Self::DEFAULT_MAX_ABS_ANGLE_DEG,
            max_abs_value: Self::DEFAULT_MAX_ABS_VALUE,
            max_columns: Self::DEFAULT_MAX_COLUMNS,
            max_line_bytes: Self::DEFAULT_MAX_LINE_BYTES,
            deadline: None,
            csv_dialect: CsvDialect::Plain,
        }
    }
}

/// The quantities whose magnitudes [`Limits`] bounds, with the unit mistake that most
/// often puts a value beyond its bound (said in the message that refuses it).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Quantity {
    /// Sample and log times, s.
    Time,
    /// Axis positions, targets and point coordinates, mm.
    Position,
    /// Measured deviations, µm.
    Deviation,
    /// Temperatures, °C.
    Temperature,
    /// Commanded angles of rotary axes, degrees.
    Angle,
    /// Any other numeric column (drift-log channels).
    Value,
}

impl Quantity {
    /// The largest |value| accepted.
    pub fn bound(self, l: &Limits) -> f64 {
        match self {
            Quantity::Time => l.max_abs_time_s,
            Quantity::Position => l.max_abs_position_mm,
            Quantity::Deviation => l.max_abs_deviation_um,
            Quantity::Temperature => l.max_abs_temperature_c,
            Quantity::Angle => l.max_abs_angle_deg,
            Quantity::Value => l.max_abs_value,
        }
    }

    /// The quantity and its unit, for messages.
    pub fn what(self) -> &'static str {
        match self {
            Quantity::Time => "time (s)",
            Quantity::Position => "position (mm)",
            Quantity::Deviation => "deviation (µm)",
            Quantity::Temperature => "temperature (°C)",
            Quantity::Angle => "angle (°)",
            Quantity::Value => "value",
        }
    }

    /// Why `v` is refused as this quantity under `l` (`None`: within its bound): the
    /// value, the bound and the unit mistake that most often causes it. One message for a
    /// CSV cell and a number of session.json alike.
    pub fn beyond(self, v: f64, l: &Limits) -> Option<String> {
        let max = self.bound(l);
        (v.abs() > max).then(|| {
            format!(
                "{v:e} is beyond the plausible {} of ±{max} ({}; the limit is configurable)",
                self.what(),
                self.hint()
            )
        })
    }

    /// What to change when a value is beyond the bound.
    pub fn hint(self) -> &'static str {
        match self {
            Quantity::Time => {
                "times are seconds from the start of the measurement: milliseconds or a \
                 clock time where seconds are required?"
            }
            Quantity::Position => {
                "micrometres where millimetres are required? divide the column by 1000"
            }
            Quantity::Deviation => {
                "nanometres where micrometres are required? divide the column by 1000"
            }
            Quantity::Angle => "arc-seconds where degrees are required? divide the column by 3600",
            Quantity::Temperature | Quantity::Value => "a unit mistake?",
        }
    }
}
