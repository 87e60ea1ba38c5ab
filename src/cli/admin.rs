//! `mtcal admin`: API keys, directly on the database.

use anyhow::Context;
use mtcal_store::Scope;
use std::process::ExitCode;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(clap::Subcommand)]
pub enum Command {
    /// Create an API key; prints the secret (shown once, stored hashed).
    CreateKey {
        /// Database: a SQLite file path or `sqlite://PATH`, or `postgres://…`.
        #[arg(long, env = "MTCAL_DB", default_value = "mtcal.sqlite")]
        db: String,
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
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
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
            let file = db.strip_prefix("sqlite://").unwrap_or(&db);
            let is_file = !(db.starts_with("postgres://")
                || db.starts_with("postgresql://")
                || db.starts_with("sqlite::memory:"));
            if is_file && !create && !std::path::Path::new(file).exists() {
                return Err(super::BadInput(format!(
                    "--db {db}: no such database (give --create to make a new one)"
                ))
                .into());
            }
            let rt = tokio::runtime::Runtime::new()?;
            let (key, secret) = rt.block_on(async {
                let store = mtcal_store::open(&db)
                    .await
                    .with_context(|| format!("opening {db}"))?;
                anyhow::Ok(store.create_key(scope, &label).await?)
            })?;
            eprintln!(
                "created key {} ({}, scope {}); the secret below is shown once:",
                key.id,
                key.label,
                key.scope.as_str()
            );
            println!("{secret}");
            Ok(ExitCode::SUCCESS)
        }
    }
}
