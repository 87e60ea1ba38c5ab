//! `mtcal admin`: API keys, directly on the database (for the first admin key, and for
//! operators with access to the database; the same operations exist as admin API routes
//! under `/api/v1/keys`).

use anyhow::Context;
use mtcal_store::{ApiKey, Scope, Store};
use std::process::ExitCode;
use std::sync::Arc;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

/// The database an admin command works on.
#[derive(clap::Args)]
pub struct DbArgs {
    /// Database: a SQLite file path or `sqlite://PATH`, or `postgres://…`.
    #[arg(long, env = "MTCAL_DB", default_value = "mtcal.sqlite")]
    db: String,
}

#[derive(clap::Subcommand)]
pub enum Command {
    /// Create an API key; prints the secret (shown once, stored hashed).
    CreateKey {
        #[command(flatten)]
        db: DbArgs,
        /// Create the SQLite file when it does not exist (else a typo in --db is refused
        /// instead of making a new empty database whose keys the service never sees).
        #[arg(long)]
        create: bool,
        /// read, write or admin.
        #[arg(long, default_value = "write")]
        scope: String,
        /// Who or what the key is for.
        #[arg(long, default_value = "cli")]
        label: String,
    },
    /// List the API keys (id, prefix, scope, label, created, revoked); never a secret.
    ListKeys {
        #[command(flatten)]
        db: DbArgs,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Revoke an API key by id: from the next request on it authenticates nothing.
    RevokeKey {
        #[command(flatten)]
        db: DbArgs,
        /// The key's id (`key_…`, see `list-keys`).
        id: String,
    },
}

/// Opens the database; a SQLite file must exist unless `create`.
async fn open(db: &str, create: bool) -> anyhow::Result<Arc<dyn Store>> {
    let file = db.strip_prefix("sqlite://").unwrap_or(db);
    let is_file = !(db.starts_with("postgres://")
        || db.starts_with("postgresql://")
        || db.starts_with("sqlite::memory:"));
    if is_file && !create && !std::path::Path::new(file).exists() {
        let hint = if create {
            ""
        } else {
            " (give --create to make a new one)"
        };
        return Err(super::BadInput(format!("--db {db}: no such database{hint}")).into());
    }
    mtcal_store::open(db)
        .await
        .with_context(|| format!("opening {}", mtcal_store::redacted(db)))
}

fn table(keys: &[ApiKey]) -> String {
    let mut out = format!(
        "{:<30} {:<10} {:<6} {:<21} {:<21} label\n",
        "id", "prefix", "scope", "created", "revoked"
    );
    for k in keys {
        out.push_str(&format!(
            "{:<30} {:<10} {:<6} {:<21} {:<21} {}\n",
            k.id,
            k.prefix,
            k.scope.as_str(),
            k.created_at,
            k.revoked_at.as_deref().unwrap_or("-"),
            k.label
        ));
    }
    out
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let rt = tokio::runtime::Runtime::new()?;
    match args.command {
        Command::CreateKey {
            db,
            scope,
            label,
            create,
        } => {
            let scope = Scope::parse(&scope).ok_or_else(|| {
                super::BadInput(format!("--scope {scope:?}: read, write or admin"))
            })?;
            let (key, secret) = rt.block_on(async {
                let store = open(&db.db, create).await?;
                anyhow::Ok(store.create_key(scope, &label).await?)
            })?;
            super::out::noteln!(
                "created key {} ({}, scope {}); the secret below is shown once:",
                key.id,
                key.label,
                key.scope.as_str()
            );
            super::out::outln!("{secret}")?;
        }
        Command::ListKeys { db, json } => {
            let keys =
                rt.block_on(async { anyhow::Ok(open(&db.db, false).await?.list_keys().await?) })?;
            if json {
                super::out::write(&(serde_json::to_string_pretty(&keys)? + "\n"))?;
            } else {
                super::out::write(&table(&keys))?;
            }
        }
        Command::RevokeKey { db, id } => {
            let key = rt.block_on(async {
                let store = open(&db.db, false).await?;
                match store.revoke_key(&id).await {
                    Err(mtcal_store::StoreError::NotFound(_)) => Err(super::BadInput(format!(
                        "no key {id} in {} (see `mtcal admin list-keys`)",
                        db.db
                    ))
                    .into()),
                    other => anyhow::Ok(other?),
                }
            })?;
            super::out::noteln!(
                "key {} ({}, scope {}) revoked at {}",
                key.id,
                key.label,
                key.scope.as_str(),
                key.revoked_at.as_deref().unwrap_or("?")
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
