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
//! validate unchanged (tested in `tests` below against the files).

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
                let text = std::fs::read_to_string(file).unwrap();
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
}
