//! The schema migrations, embedded at build time (`build.rs` lists
//! `migrations/<dialect>/<version>_<description>.sql`) and applied by sqlx's
//! [`Migrator`] when a store opens.
//!
//! sqlx's own `migrate!` macro does the same, but it needs the query-macro machinery,
//! which builds both database drivers (and the bundled SQLite C library) a second time
//! for the compiler host: minutes of a 2-core build. A migration here is what the macro
//! made of the same file: description = the file name's words, checksum = SHA-384 of the
//! file's text (computed by [`Migration::new`]), in its own transaction unless the file
//! starts with `-- no-transaction`. Databases migrated by earlier builds therefore
//! validate unchanged (tested in `tests` below against the files, and against the
//! checksums those databases recorded).
//!
//! A migration that both dialects accept as written is one file: its
//! `migrations/postgres/<version>_<description>.sql` is a symbolic link to the SQLite
//! folder's file of the same name (the build reads through the link: the same text, the
//! same checksum; where git checks a link out as a plain file holding its target, as on
//! Windows, `build.rs` follows that text instead). The others are two files, one per dialect, and differ where the
//! dialects do (PostgreSQL's `BIGINT`, `DOUBLE PRECISION` and byte-wise `COLLATE "C"`).

use sqlx::SqlSafeStr as _;
use sqlx::migrate::{Migration, MigrationSource, MigrationType, Migrator};
use std::borrow::Cow;
use std::future::Future;
use std::pin::Pin;

/// `(version, description, SQL)` of each migration of one dialect, in version order.
pub(crate) type Embedded = &'static [(i64, &'static str, &'static str)];

/// The migrations of `migrations/sqlite`.
pub(crate) const SQLITE: Embedded = include!(concat!(env!("OUT_DIR"), "/migrations_sqlite.rs"));
/// The migrations of `migrations/postgres`.
pub(crate) const POSTGRES: Embedded = include!(concat!(env!("OUT_DIR"), "/migrations_postgres.rs"));

/// One dialect's embedded migrations as a sqlx [`MigrationSource`].
#[derive(Debug)]
struct Source(Embedded);

impl MigrationSource<'static> for Source {
    fn resolve(
        self,
    ) -> Pin<Box<dyn Future<Output = Result<Vec<Migration>, sqlx::error::BoxDynError>> + Send>>
    {
        Box::pin(async move { Ok(migrations(self.0)) })
    }
}

/// The [`Migration`]s of `embedded`.
fn migrations(embedded: Embedded) -> Vec<Migration> {
    embedded
        .iter()
        .map(|&(version, description, sql)| {
            Migration::new(
                version,
                Cow::Borrowed(description),
                MigrationType::Simple,
                sql.into_sql_str(),
                sql.starts_with("-- no-transaction"),
            )
        })
        .collect()
}

/// The migrator of `embedded`.
pub(crate) async fn migrator(embedded: Embedded) -> crate::Result<Migrator> {
    use crate::error::Db as _;
    Migrator::new(Source(embedded)).await.db()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sha2::{Digest, Sha384};

    /// Every `.sql` file of a dialect's folder is embedded once, in version order, with the
    /// checksum a database migrated by sqlx's `migrate!` recorded: SHA-384 of the file.
    #[test]
    fn embedded_migrations_are_the_files_with_their_checksums() {
        for (dialect, embedded) in [("sqlite", SQLITE), ("postgres", POSTGRES)] {
            let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../migrations")
                .join(dialect);
            let mut files: Vec<_> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            files.sort();
            assert_eq!(files.len(), embedded.len(), "{dialect}");
            let resolved = migrations(embedded);
            for ((file, migration), (n, _, _)) in files.iter().zip(&resolved).zip(embedded) {
                let mut text = std::fs::read_to_string(file).unwrap();
                if text.starts_with("../sqlite/") {
                    // A link checked out as a plain file holding its target (build.rs).
                    text = std::fs::read_to_string(dir.join(&text)).unwrap();
                }
                let name = file.file_name().unwrap().to_str().unwrap();
                assert_eq!(name[..4].parse::<i64>().unwrap(), *n, "{name}");
                assert_eq!(migration.version, *n);
                assert_eq!(migration.sql.as_str(), text, "{name}");
                assert_eq!(
                    &*migration.checksum,
                    &Sha384::digest(text.as_bytes())[..],
                    "{name}"
                );
                let words = name[5..].trim_end_matches(".sql").replace('_', " ");
                assert_eq!(migration.description, words, "{name}");
            }
        }
    }

    /// The migrations databases have applied keep the checksums they recorded (the first
    /// 12 bytes of each SHA-384, as applied by every earlier build): a migration is never
    /// edited, only added. This holds the files, and the links by which a migration both
    /// dialects accept as written is one file (`migrations/postgres/N_….sql` →
    /// `../sqlite/N_….sql`), to what was applied.
    #[test]
    fn applied_migrations_keep_their_checksums() {
        const APPLIED: &[(&str, i64, &str)] = &[
            ("sqlite", 1, "c23215f7ba979c163407713a"),
            ("sqlite", 2, "e705f8af07d13987f58b19e1"),
            ("sqlite", 3, "57d3fe838511312387947877"),
            ("sqlite", 4, "4fd00d7967295dc2f7e0c867"),
            ("sqlite", 5, "03a81cc902614176644eda31"),
            ("sqlite", 6, "0d7a1b1508c0013dbad28b7f"),
            ("sqlite", 7, "1fc0db78b7e5417ecac46020"),
            ("sqlite", 8, "db2a2143fe25289185a8b095"),
            ("sqlite", 9, "ad9c4bb6596302573caf5666"),
            ("sqlite", 10, "771e8b39bf9f288abc4a927b"),
            ("sqlite", 11, "0499946f0531a05ab2d152e9"),
            ("sqlite", 12, "d3ec9ce583af5679158a8a5b"),
            ("sqlite", 13, "3fdb9b7a3b4a5fe1dd6589e0"),
            ("postgres", 1, "f7d07f97cde8b944d1343952"),
            ("postgres", 2, "e705f8af07d13987f58b19e1"),
            ("postgres", 3, "3bea4ac952864d1d1cff781b"),
            ("postgres", 4, "4fd00d7967295dc2f7e0c867"),
            ("postgres", 5, "ca92efb82969d1e0795f4194"),
            ("postgres", 6, "0d7a1b1508c0013dbad28b7f"),
            ("postgres", 7, "1fc0db78b7e5417ecac46020"),
            ("postgres", 8, "db2a2143fe25289185a8b095"),
            ("postgres", 9, "ad9c4bb6596302573caf5666"),
            ("postgres", 10, "771e8b39bf9f288abc4a927b"),
            ("postgres", 11, "d596b9f4fb0852525a662f26"),
            ("postgres", 12, "d3ec9ce583af5679158a8a5b"),
            ("postgres", 13, "5fb84b7fe3f9d3ffd8194c54"),
        ];
        for &(dialect, version, prefix) in APPLIED {
            let embedded = if dialect == "sqlite" {
                SQLITE
            } else {
                POSTGRES
            };
            let m = migrations(embedded)
                .into_iter()
                .find(|m| m.version == version)
                .unwrap_or_else(|| panic!("{dialect} {version}: missing"));
            let hex: String = m.checksum[..12]
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            assert_eq!(hex, prefix, "{dialect} {version}");
        }
    }

    /// A link in `migrations/postgres` names the SQLite migration of the same file name:
    /// one version's text for both dialects, never another version's.
    #[test]
    fn linked_migrations_are_the_same_version() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../migrations");
        for entry in std::fs::read_dir(root.join("postgres")).unwrap() {
            let path = entry.unwrap().path();
            let Ok(target) = std::fs::read_link(&path) else {
                continue;
            };
            let name = path.file_name().unwrap();
            assert_eq!(
                target,
                std::path::Path::new("../sqlite").join(name),
                "{}",
                path.display()
            );
        }
    }
}
