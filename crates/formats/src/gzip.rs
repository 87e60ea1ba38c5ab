//! Transparent gzip decompression (datasets contract: files may be gzip-compressed,
//! `.csv.gz` names or gzip content), bounded by the byte budget of the upload.

use crate::FormatError;
use std::borrow::Cow;
use std::io::Read;

/// The two magic bytes that start every gzip member (RFC 1952, section 2.3.1).
pub const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

pub(crate) fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&GZIP_MAGIC)
}

/// The bytes of `file`, decompressed when they are gzip; their (decompressed) size is
/// charged to `budget` (bytes still allowed in this upload). Rejects a `.gz` name whose
/// content is not gzip, corrupt gzip and anything that would exceed the budget (checked
/// while decompressing, so a small compressed file cannot expand without bound).
pub(crate) fn decode<'a>(
    file: &str,
    bytes: &'a [u8],
    budget: &mut usize,
) -> Result<Cow<'a, [u8]>, FormatError> {
    let over = |n: usize| {
        FormatError::file(
            file,
            format!(
                "upload exceeds the byte limit ({n} bytes allowed in what remains of the upload)"
            ),
        )
        .as_limit()
    };
    if !is_gzip(bytes) {
        if file.ends_with(".gz") {
            return Err(FormatError::file(
                file,
                "file name ends in .gz but the content is not gzip",
            ));
        }
        if bytes.len() > *budget {
            return Err(over(*budget));
        }
        *budget -= bytes.len();
        return Ok(Cow::Borrowed(bytes));
    }
    let mut out = Vec::new();
    let mut dec = flate2::read::MultiGzDecoder::new(bytes).take(*budget as u64 + 1);
    dec.read_to_end(&mut out)
        .map_err(|e| FormatError::file(file, format!("invalid gzip data: {e}")))?;
    if out.len() > *budget {
        return Err(over(*budget));
    }
    *budget -= out.len();
    Ok(Cow::Owned(out))
}

/// Up to `max` leading bytes of the (possibly gzip) content, for sniffing; `None` when
/// the gzip stream is corrupt before `max` bytes.
pub(crate) fn prefix(bytes: &[u8], max: usize) -> Option<Cow<'_, [u8]>> {
    if !is_gzip(bytes) {
        return Some(Cow::Borrowed(&bytes[..bytes.len().min(max)]));
    }
    let mut out = Vec::new();
    let mut dec = flate2::read::MultiGzDecoder::new(bytes).take(max as u64);
    match dec.read_to_end(&mut out) {
        Ok(_) => Some(Cow::Owned(out)),
        // A truncated stream still yields what was decoded before the cut.
        Err(_) if !out.is_empty() => Some(Cow::Owned(out)),
        Err(_) => None,
    }
}
