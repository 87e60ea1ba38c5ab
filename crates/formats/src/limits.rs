//! Size limits applied while reading (datasets contract, "Rules for every format":
//! limits are configurable; defaults 5 million samples per file, 256 MiB per upload), and
//! plausibility bounds on magnitudes: a finite but absurd value (a deviation of 1e308 µm,
//! a position in µm where mm are required) is refused at the cell that holds it, naming
//! the file, line and column, instead of reaching the solver.

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
        }
    }
}
