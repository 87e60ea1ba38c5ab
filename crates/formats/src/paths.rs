//! Files read by path for the path-based readers: bounded reads, the names messages
//! give them, and the errors of a path a user gave.

use crate::error::FormatError;
use crate::gzip;
use crate::limits::Limits;

/// Reads a whole file for a path-based reader, mapping IO errors to a [`FormatError`]
/// and refusing files larger than the byte limit before reading them.
pub(crate) fn read_file_limited(
    path: &std::path::Path,
    name: &str,
    limits: &Limits,
) -> Result<Vec<u8>, FormatError> {
    read_file_into(path, name, limits, Vec::new())
}

/// [`read_file_limited`] into `buf`, emptied first: its memory is reused (a session's
/// plane files are read one after the other into the buffers of the files already
/// parsed, so their pages are not faulted in anew for every file).
pub(crate) fn read_file_into(
    path: &std::path::Path,
    name: &str,
    limits: &Limits,
    mut buf: Vec<u8>,
) -> Result<Vec<u8>, FormatError> {
    use std::io::Read;
    let cannot = |e: std::io::Error| FormatError::file(name, format!("cannot read file: {e}"));
    let mut file = std::fs::File::open(path).map_err(cannot)?;
    let len = file.metadata().map_err(cannot)?.len();
    if len > limits.max_bytes as u64 {
        return Err(FormatError::file(
            name,
            format!(
                "upload exceeds the byte limit ({} bytes allowed in what remains of the upload)",
                limits.max_bytes
            ),
        )
        .as_limit());
    }
    buf.clear();
    buf.reserve_exact(len as usize);
    file.read_to_end(&mut buf).map_err(cannot)?;
    Ok(buf)
}

/// The metadata of a dataset path given by a user, or an error naming the full path and
/// the system's reason (`/no/such/dir: cannot read: No such file or directory (os
/// error 2)`).
pub fn stat_path(path: &std::path::Path) -> Result<std::fs::Metadata, FormatError> {
    std::fs::metadata(path)
        .map_err(|e| FormatError::file(path.display().to_string(), format!("cannot read: {e}")))
}

/// The file name of a path, for messages.
pub(crate) fn display_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Reads a single-file dataset given by path (still compressed if it is gzip: the
/// byte-based readers decompress); returns its display name and contents.
pub(crate) fn read_single(
    path: &std::path::Path,
    limits: &Limits,
) -> Result<(String, Vec<u8>), FormatError> {
    let name = display_name(path);
    let raw = read_file_limited(path, &name, limits)?;
    Ok((name, raw))
}

/// Decompresses (when gzip) one uploaded file under the byte limit.
pub(crate) fn decode_single<'a>(
    name: &str,
    bytes: &'a [u8],
    limits: &Limits,
) -> Result<std::borrow::Cow<'a, [u8]>, FormatError> {
    let mut budget = limits.max_bytes;
    gzip::decode(name, bytes, &mut budget)
}

/// Shared by the writers: an `InvalidInput` error.
pub(crate) fn invalid_input(msg: impl Into<String>) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, msg.into())
}
