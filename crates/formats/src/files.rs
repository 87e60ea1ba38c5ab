//! The files of one read, wherever they are: their names and a loader of each one's
//! bytes as stored (still compressed when gzip). An upload's parts and an archive's
//! entries are in memory; a folder's files are read from disk when loaded, each under
//! what remains of the byte limit. The session and upload readers take their files
//! through here.

use crate::{FormatError, Limits};
use std::borrow::Cow;
use std::path::Path;

/// A loader of files by name, as stored. The second argument is an emptied buffer the
/// loader may read the file into (a folder's loader does; files in memory are returned
/// as they are): a reader hands back the buffers of files it has parsed.
pub(crate) type Loader<'a> = dyn FnMut(&str, Vec<u8>) -> Result<Cow<'a, [u8]>, FormatError> + 'a;

/// The regular files of a folder (sorted names) and a loader reading each under what
/// remains of the byte limit.
pub(crate) fn folder<'a>(
    dir: &'a Path,
    limits: &Limits,
) -> Result<(Vec<String>, Box<Loader<'a>>), FormatError> {
    let shown = || dir.display().to_string();
    let entries = std::fs::read_dir(dir)
        .map_err(|e| FormatError::file(shown(), format!("cannot read the folder: {e}")))?;
    let mut names = Vec::new();
    for e in entries {
        let e =
            e.map_err(|e| FormatError::file(shown(), format!("cannot read the folder: {e}")))?;
        if e.path().is_file() {
            names.push(e.file_name().to_string_lossy().into_owned());
        }
    }
    names.sort();
    let mut remaining = limits.max_bytes;
    let limits = *limits;
    let load = move |name: &str, spare: Vec<u8>| -> Result<Cow<'a, [u8]>, FormatError> {
        let bytes = crate::read_file_into(
            &dir.join(name),
            name,
            &Limits {
                max_bytes: remaining,
                ..limits
            },
            spare,
        )?;
        remaining -= bytes.len();
        Ok(Cow::Owned(bytes))
    };
    Ok((names, Box::new(load)))
}
