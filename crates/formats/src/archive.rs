//! Archives as a person makes them: `.tar`, `.tar.gz` (`.tgz`) and `.zip`, made with
//! `tar czf s.tgz -C dir .`, `tar czf s.tgz dir`, `zip -r s.zip dir` or a file manager,
//! with or without a top folder. An archive is read as the files inside it, folders
//! flattened, so the dataset may sit at the top or in one folder.
//!
//! What is refused, with the archive and the entry named: an absolute path or one with
//! `..`; a link, a device or a FIFO; an encrypted zip entry or one compressed with a
//! method other than deflate or store; two files of the same name; more than
//! [`Limits::max_files`] files or [`MAX_FOLDERS`] folders; more decompressed bytes than
//! [`Limits::max_bytes`] (counted while decompressing, so a small archive cannot expand
//! without bound). AppleDouble `._*` entries and `.DS_Store` files are skipped.

use crate::limits::MAX_NAME_LEN;
use crate::{FormatError, Limits, gzip};
use std::io::Read;

/// Largest number of folder entries in one archive (its files are bounded by
/// [`Limits::max_files`]).
pub const MAX_FOLDERS: usize = 256;

/// The local file header signature that starts a zip archive (and an empty one's end of
/// central directory record).
const ZIP_MAGIC: [&[u8]; 2] = [b"PK\x03\x04", b"PK\x05\x06"];

/// Whether a name is an archive's (`.tar`, `.tar.gz`, `.tgz`, `.zip`).
pub fn is_archive_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    [".tar", ".tar.gz", ".tgz", ".zip"]
        .iter()
        .any(|x| n.ends_with(x))
}

/// The files of an upload with a single archive among them unpacked: an upload of exactly
/// one file that is an archive (by its name, see [`is_archive_name`], or by its content:
/// a zip signature, or a tar header after any gzip) is read as the files inside it, as
/// when the archive is the request's body; any other upload is returned as it is. So an
/// archive reads the same whether it is sent as the body, as a multipart file or through
/// the dashboard's form.
pub fn unpack_single_archive(
    files: Vec<(String, Vec<u8>)>,
    limits: &Limits,
) -> Result<Vec<(String, Vec<u8>)>, FormatError> {
    match files.as_slice() {
        [(name, bytes)] if is_archive_name(name) || is_zip(bytes) || is_tar(bytes) => {
            read_archive(name, bytes, limits)
        }
        _ => Ok(files),
    }
}

fn is_zip(bytes: &[u8]) -> bool {
    ZIP_MAGIC.iter().any(|m| bytes.starts_with(m))
}

/// Whether `bytes` (gzip-compressed or not) hold a tar archive: the POSIX `ustar` magic
/// of the first header, at byte 257.
fn is_tar(bytes: &[u8]) -> bool {
    const MAGIC: &[u8] = b"ustar";
    let at = |b: &[u8]| b.len() > 262 && &b[257..262] == MAGIC;
    // Only the first header is needed: a bounded decode of the start.
    gzip::prefix(bytes, 512).is_some_and(|head| at(&head))
}

/// The files of an archive (`name` is the archive's, for messages): a zip when the
/// content starts with a zip signature, otherwise a tar, gzip-compressed or not. See the
/// module documentation for what is refused.
pub fn read_archive(
    name: &str,
    bytes: &[u8],
    limits: &Limits,
) -> Result<Vec<(String, Vec<u8>)>, FormatError> {
    let mut entries = Entries::new(name, limits);
    if is_zip(bytes) {
        read_zip(&mut entries, bytes)?;
    } else {
        read_tar(&mut entries, bytes)?;
    }
    entries.finish()
}

fn read_tar(entries: &mut Entries<'_>, bytes: &[u8]) -> Result<(), FormatError> {
    let mut budget = entries.limits.max_bytes;
    let tar_bytes = gzip::decode(entries.archive, bytes, &mut budget)?;
    let mut archive = tar::Archive::new(tar_bytes.as_ref());
    let list = archive
        .entries()
        .map_err(|e| entries.bad(format!("not a tar or zip archive: {e}")))?;
    for entry in list {
        entries.tick()?;
        let entry = entry.map_err(|e| entries.bad(format!("unreadable entry: {e}")))?;
        let raw_path = String::from_utf8_lossy(&entry.path_bytes()).into_owned();
        use tar::EntryType as T;
        let kind = match entry.header().entry_type() {
            T::Regular | T::Continuous => Kind::File,
            T::Directory => Kind::Folder,
            T::XGlobalHeader | T::XHeader | T::GNULongName | T::GNULongLink => continue,
            T::Symlink => Kind::Refused("a symbolic link"),
            T::Link => Kind::Refused("a hard link"),
            T::Char | T::Block => Kind::Refused("a device"),
            T::Fifo => Kind::Refused("a FIFO"),
            _ => Kind::Refused("not a regular file"),
        };
        entries.add(&raw_path, kind, entry)?;
    }
    Ok(())
}

fn read_zip(entries: &mut Entries<'_>, bytes: &[u8]) -> Result<(), FormatError> {
    if bytes.len() > entries.limits.max_bytes {
        return Err(entries.over_budget());
    }
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| entries.bad(format!("not a readable zip archive: {e}")))?;
    for i in 0..archive.len() {
        entries.tick()?;
        let (raw_path, kind) = {
            let f = archive
                .by_index_raw(i)
                .map_err(|e| entries.bad(format!("unreadable entry {}: {e}", i + 1)))?;
            let method = f.compression();
            let kind = if f.is_symlink() {
                Kind::Refused("a symbolic link")
            } else if f.is_dir() {
                Kind::Folder
            } else if f.encrypted() {
                Kind::Encrypted
            } else if !matches!(
                method,
                zip::CompressionMethod::Deflated | zip::CompressionMethod::Stored
            ) {
                Kind::Unsupported(method.to_string())
            } else {
                Kind::File
            };
            (f.name().to_string(), kind)
        };
        if let Kind::File = kind {
            let f = archive
                .by_index(i)
                .map_err(|e| entries.bad(format!("entry `{raw_path}`: {e}")))?;
            entries.add(&raw_path, kind, f)?;
        } else {
            entries.add(&raw_path, kind, std::io::empty())?;
        }
    }
    Ok(())
}

/// What an archive entry is.
enum Kind {
    File,
    Folder,
    /// Refused: says what it is.
    Refused(&'static str),
    /// An encrypted zip entry.
    Encrypted,
    /// A zip entry compressed with this method.
    Unsupported(String),
}

/// The files read from an archive so far, with the checks every entry passes.
struct Entries<'a> {
    archive: &'a str,
    limits: &'a Limits,
    /// Decompressed bytes still allowed.
    budget: usize,
    folders: usize,
    out: Vec<(String, Vec<u8>)>,
}

impl<'a> Entries<'a> {
    fn new(archive: &'a str, limits: &'a Limits) -> Self {
        Entries {
            archive,
            limits,
            budget: limits.max_bytes,
            folders: 0,
            out: Vec::new(),
        }
    }

    fn bad(&self, rule: String) -> FormatError {
        FormatError::file(self.archive, rule)
    }

    fn over_budget(&self) -> FormatError {
        self.bad(format!(
            "the archive unpacks to more than the byte limit of {} bytes per upload",
            self.limits.max_bytes
        ))
        .as_limit()
    }

    /// Stops at the reader's deadline (checked once per entry).
    fn tick(&self) -> Result<(), FormatError> {
        self.limits.check_deadline(self.archive, 0)
    }

    /// Checks one entry and keeps it when it is a file (its content read from `data`,
    /// bounded by what remains of the byte limit).
    fn add(&mut self, raw_path: &str, kind: Kind, mut data: impl Read) -> Result<(), FormatError> {
        let shown: String = raw_path.chars().take(MAX_NAME_LEN).collect();
        let entry_bad = |rule: &str| self.bad(format!("entry `{shown}`{rule}"));
        match kind {
            Kind::File => {}
            Kind::Folder => {
                self.folders += 1;
                if self.folders > MAX_FOLDERS {
                    return Err(self
                        .bad(format!("more than {MAX_FOLDERS} folders in the archive"))
                        .as_limit());
                }
                return Ok(());
            }
            Kind::Refused(what) => {
                return Err(entry_bad(&format!(
                    " is {what}: an archive may hold only files and folders"
                )));
            }
            Kind::Encrypted => {
                return Err(entry_bad(
                    " is encrypted: make the archive without a password",
                ));
            }
            Kind::Unsupported(method) => {
                return Err(entry_bad(&format!(
                    " is compressed with {method}: make the zip with deflate, the default of \
                     `zip` and of file managers"
                )));
            }
        }
        if raw_path.starts_with('/')
            || raw_path.starts_with('\\')
            || raw_path.split(['/', '\\']).any(|c| c == "..")
        {
            return Err(entry_bad(
                ": absolute paths and `..` are not allowed in an archive",
            ));
        }
        let file = raw_path
            .rsplit(['/', '\\'])
            .next()
            .unwrap_or_default()
            .to_string();
        if file.starts_with("._") || file == ".DS_Store" {
            return Ok(()); // metadata written by macOS tar and Finder
        }
        if self.out.len() == self.limits.max_files {
            return Err(self
                .bad(format!(
                    "more than {} files in the archive",
                    self.limits.max_files
                ))
                .as_limit());
        }
        if self.out.iter().any(|(n, _)| *n == file) {
            return Err(entry_bad(&format!(
                ": a file named `{file}` is already in the archive (folders are flattened)"
            )));
        }
        let mut bytes = Vec::new();
        (&mut data)
            .take(self.budget as u64 + 1)
            .read_to_end(&mut bytes)
            .map_err(|e| entry_bad(&format!(": {e}")))?;
        if bytes.len() > self.budget {
            return Err(self.over_budget());
        }
        self.budget -= bytes.len();
        self.out.push((file, bytes));
        Ok(())
    }

    fn finish(self) -> Result<Vec<(String, Vec<u8>)>, FormatError> {
        if self.out.is_empty() {
            return Err(self.bad("no files in the archive".into()));
        }
        Ok(self.out)
    }
}
