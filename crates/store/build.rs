//! Embeds the SQL migrations of `migrations/sqlite` and `migrations/postgres` (workspace
//! root) at build time: writes `$OUT_DIR/migrations_<dialect>.rs`, a slice of
//! `(version, description, include_str!(file))` in version order, read by
//! `src/migrations.rs`. Files follow sqlx's naming, `<version>_<description>.sql`; any other
//! file in the folder is a build error (a misnamed migration must not be skipped silently).

use std::fmt::Write as _;
use std::path::Path;

/// The file a migration's text is read from: `path` itself, or, where `path` is a link to
/// `../sqlite/…` that git checked out as a plain file holding the link's target (a
/// checkout with `core.symlinks` off, the default on Windows), that target. A real link
/// is read through by the file system.
fn followed(dir: &Path, path: std::path::PathBuf) -> std::path::PathBuf {
    let text = std::fs::read_to_string(&path).expect("readable migration");
    match text.strip_prefix("../sqlite/") {
        Some(name) if name.ends_with(".sql") && !name.contains(['/', '\\', '\n']) => {
            // The same version's text for both dialects, never another version's.
            assert_eq!(
                Some(std::ffi::OsStr::new(name)),
                path.file_name(),
                "{}: a link to another migration",
                path.display()
            );
            println!("cargo:rerun-if-changed={}", dir.join(&text).display());
            dir.join(text)
        }
        _ => path,
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations");
    let out = std::env::var("OUT_DIR").expect("cargo sets OUT_DIR");
    for dialect in ["sqlite", "postgres"] {
        let dir = root
            .join(dialect)
            .canonicalize()
            .expect("migrations folder");
        println!("cargo:rerun-if-changed={}", dir.display());
        let mut files = Vec::new();
        for entry in std::fs::read_dir(&dir).expect("readable migrations folder") {
            let path = entry.expect("readable folder entry").path();
            println!("cargo:rerun-if-changed={}", path.display());
            let name = path
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            let parsed = name
                .strip_suffix(".sql")
                .and_then(|stem| stem.split_once('_'))
                .and_then(|(v, d)| Some((v.parse::<i64>().ok()?, d.replace('_', " "))));
            let Some((version, description)) = parsed else {
                panic!("{}: not <version>_<description>.sql", path.display());
            };
            files.push((version, description, followed(&dir, path)));
        }
        files.sort_by_key(|f| f.0);
        let mut code = String::from("&[\n");
        for (version, description, path) in &files {
            writeln!(
                code,
                "    ({version}, {description:?}, include_str!({:?})),",
                path
            )
            .expect("write to a String");
        }
        code.push(']');
        std::fs::write(
            Path::new(&out).join(format!("migrations_{dialect}.rs")),
            code,
        )
        .expect("writable OUT_DIR");
    }
}
