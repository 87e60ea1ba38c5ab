//! Size limits applied while reading (datasets contract, "Rules for every format":
//! limits are configurable; defaults 5 million samples per file, 256 MiB per upload).

/// Limits applied by every reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Largest number of data rows (samples) accepted in one CSV file.
    pub max_samples_per_file: usize,
    /// Largest number of bytes accepted in one upload (one call of a reader), counted
    /// both as stored and after gzip decompression, summed over all files of the upload.
    pub max_bytes: usize,
    /// Largest number of files in one upload or archive (folders: files read).
    pub max_files: usize,
}

impl Limits {
    pub const DEFAULT_MAX_SAMPLES_PER_FILE: usize = 5_000_000;
    pub const DEFAULT_MAX_BYTES: usize = 256 * 1024 * 1024;
    pub const DEFAULT_MAX_FILES: usize = 1000;
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_samples_per_file: Self::DEFAULT_MAX_SAMPLES_PER_FILE,
            max_bytes: Self::DEFAULT_MAX_BYTES,
            max_files: Self::DEFAULT_MAX_FILES,
        }
    }
}
