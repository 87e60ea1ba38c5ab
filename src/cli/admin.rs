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
        /// Database: a SQLite file path or `sqlite://PATH`.
        #[arg(long, default_value = "mtcal.sqlite")]
        db: String,
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
        Command::CreateKey { db, scope, label } => {
            let scope = Scope::parse(&scope).ok_or_else(|| {
                super::BadInput(format!("--scope {scope:?}: read, write or admin"))
            })?;
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
