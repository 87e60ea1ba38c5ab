//! # mtcal-formats
//!
//! Strict readers (and writers) of the dataset formats in `docs/datasets.md`: every
//! rejected file gets an error naming the file, the line, the column and the rule, and
//! nothing of a rejected upload is returned.
//!
//! * [`session`]: measurement sessions (section 1: `session.json` + plane CSVs);
//! * [`rotary`]: rotary-axis point sets (section 2);
//! * [`positioning`]: positioning runs (section 3);
//! * [`drift`]: drift logs (section 4);
//! * [`sniff`]: which of these a file is, from its header;
//! * [`units`]: unit mistakes (millimetres in a micrometre column, micrometres in a
//!   millimetre one, radians in a degree one) refused with what to change;
//! * [`upload`]: a whole upload (files in memory, an archive, or a path), whatever its
//!   kind: the one entry point the CLI and the server share, so that both accept and
//!   refuse the same inputs;
//! * [`archive`]: `.tar`, `.tar.gz` and `.zip` archives unpacked to their files.
//!
//! The rules shared by every CSV format live once in `csv_core`, limits in [`limits`],
//! gzip handling in `gzip`, the files of one read (in memory or in a folder) in `files`.

pub mod archive;
pub mod compensation;
mod csv_core;
mod csv_out;
pub mod drift;
mod error;
mod files;
mod gzip;
mod json;
pub mod limits;
mod paths;
pub mod positioning;
pub mod rotary;
pub mod session;
pub mod sniff;
pub mod units;
pub mod upload;

pub use archive::{is_archive_name, read_archive, unpack_single_archive};
pub use drift::{read_drift_log, read_drift_log_path, write_drift_log, write_drift_predictions};
pub use error::{ErrorKind, FormatError, MAX_MESSAGE_PART};
pub use json::is_rfc3339;
pub use limits::{CsvDialect, Limits};
pub use paths::stat_path;
pub(crate) use paths::{
    decode_single, display_name, invalid_input, read_file_into, read_file_limited, read_single,
};
pub use positioning::{read_positioning, read_positioning_path, write_positioning};
pub use rotary::{
    read_rotary_points, read_rotary_points_path, write_rotary_points, write_rotary_sidecar,
};
pub use session::{read_session_dir, read_session_files, write_session_dir};
pub use sniff::{DatasetKind, sniff_kind, sniff_path};
pub use upload::{Dataset, DatasetData, read_path, read_upload};
