//! `mtcal admin`: API keys, machines and tolerance profiles, directly on the database
//! (for the first admin key, and for operators with access to the database; the same
//! operations exist as API routes: `/api/v1/keys`, `/api/v1/machines`,
//! `/api/v1/tolerances`, with the same rules, those of crates/domain).

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
        /// A site the key acts on (repeat for several); without it the key covers the
        /// whole group.
        #[arg(long = "site", value_name = "NAME")]
        sites: Vec<String>,
        /// Within those sites, only machines with this tag (repeat for several).
        #[arg(long = "tag", value_name = "TAG")]
        tags: Vec<String>,
    },
    /// List the API keys (id, prefix, scope, label, created, revoked); never a secret.
    ListKeys {
        #[command(flatten)]
        db: DbArgs,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Register a machine (as `POST /api/v1/machines` does, with the same rules).
    CreateMachine {
        #[command(flatten)]
        db: DbArgs,
        /// Its id: 1–64 letters, digits, '.', '_', '-'.
        id: String,
        /// Its name (default: the id).
        #[arg(long)]
        name: Option<String>,
        #[arg(long)]
        site: Option<String>,
        /// A tag (repeat for several); a tag's tolerance profile applies to it.
        #[arg(long = "tag")]
        tags: Vec<String>,
        /// An axis's registered travel, `X=-300:300` mm (repeat per axis).
        #[arg(long = "travel", value_parser = travel)]
        travel: Vec<(String, [f64; 2])>,
    },
    /// Create a tolerance profile (as `POST /api/v1/tolerances` does, with the same
    /// rules; a webhook is set through the API or the dashboard) and refresh the verdicts
    /// of the machines it applies to.
    CreateProfile {
        #[command(flatten)]
        db: DbArgs,
        /// `machine` (one machine's profile) or `tag` (every machine with the tag).
        #[arg(long)]
        scope: String,
        /// The machine id or the tag.
        #[arg(long)]
        target: String,
        /// The limits as JSON (docs/api.md, "Tolerances and verdicts"), e.g.
        /// '{"terms": {"EXX": {"range": 10, "per_length_mm": 300}}, "squareness": {"EC0Y": 30}}';
        /// `@FILE` reads them from a file.
        #[arg(long)]
        limits: String,
    },
    /// Revoke an API key by id: from the next request on it authenticates nothing.
    RevokeKey {
        #[command(flatten)]
        db: DbArgs,
        /// The key's id (`key_…`, see `list-keys`).
        id: String,
    },
}

/// One axis's travel, `X=-300:300` (mm).
fn travel(v: &str) -> Result<(String, [f64; 2]), String> {
    let bad = || format!("{v:?}: give AXIS=MIN:MAX in mm, e.g. X=-300:300");
    let (axis, range) = v.split_once('=').ok_or_else(bad)?;
    let (lo, hi) = range.split_once(':').ok_or_else(bad)?;
    let num = |t: &str| t.trim().parse::<f64>().map_err(|_| bad());
    Ok((axis.trim().to_string(), [num(lo)?, num(hi)?]))
}

/// A rule of the service refusing what was asked: bad input (exit code 2), with its
/// message; anything else as it is.
fn refused(e: mtcal_domain::DomainError) -> anyhow::Error {
    use mtcal_domain::DomainError as D;
    use mtcal_store::StoreError as S;
    match e {
        D::Invalid(m) | D::NotFound(m) | D::Conflict(m) => super::BadInput(m).into(),
        D::Store(S::NotFound(m) | S::Conflict(m) | S::Invalid(m)) => super::BadInput(m).into(),
        other => other.into(),
    }
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

/// Appends a change made by this command to the audit trail (docs/audit.md), as the
/// API's routes do: the actor `cli`, named by the OS user running it, through `cli`, no
/// client address. `target` is the changed record's id, `machine` the machine it
/// concerns. A change whose record is the same before and after is no event. When the
/// event cannot be written the command fails although the change was made.
async fn audit<T: serde::Serialize>(
    store: &dyn Store,
    (action, target, machine): (&str, &str, Option<&str>),
    before: Option<&T>,
    after: &T,
) -> anyhow::Result<()> {
    let json = |k: &T| serde_json::to_value(k).ok();
    let (before, after) = (before.and_then(json), json(after));
    if before.is_some() && before == after {
        return Ok(());
    }
    let user = ["USER", "USERNAME", "LOGNAME"]
        .iter()
        .find_map(|v| std::env::var(v).ok().filter(|u| !u.is_empty()));
    let event = mtcal_store::NewAuditEvent {
        actor: "cli".into(),
        actor_name: user.map_or_else(|| "cli".into(), |u| format!("OS user {u}")),
        via: "cli".into(),
        action: action.into(),
        target: target.into(),
        machine_id: machine.map(str::to_string),
        before,
        after,
        client: None,
    };
    store.record_audit(&event).await.with_context(|| {
        format!("{action} {target} was made but its audit event could not be written")
    })?;
    Ok(())
}

/// What a key acts on: `whole group`, or `sites [..]` and `tags [..]`.
fn reach(k: &ApiKey) -> String {
    if k.is_group() {
        return "whole group".into();
    }
    format!("sites {:?}, tags {:?}", k.sites, k.tags)
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
        if !k.is_group() {
            out.pop();
            out.push_str(&format!(" {}\n", reach(k)));
        }
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
            sites,
            tags,
        } => {
            let scope = Scope::parse(&scope).ok_or_else(|| {
                super::BadInput(format!("--scope {scope:?}: read, write or admin"))
            })?;
            mtcal_store::text::check_key_scope(&sites, &tags)
                .map_err(|e| super::BadInput(e.to_string()))?;
            let (key, secret) = rt.block_on(async {
                let store = open(&db.db, create).await?;
                let (key, secret) = store.create_key_in(scope, &label, &sites, &tags).await?;
                let what = ("key.create", key.id.as_str(), None);
                audit(store.as_ref(), what, None, &key).await?;
                anyhow::Ok((key, secret))
            })?;
            super::out::noteln!(
                "created key {} ({}, scope {}, {}); the secret below is shown once:",
                key.id,
                key.label,
                key.scope.as_str(),
                reach(&key)
            );
            super::out::outln!("{secret}")?;
        }
        Command::ListKeys { db, json } => {
            let keys =
                rt.block_on(async { anyhow::Ok(open(&db.db, false).await?.list_keys().await?) })?;
            super::out::document(json, &keys, |keys| table(keys))?;
        }
        Command::CreateMachine {
            db,
            id,
            name,
            site,
            tags,
            travel,
        } => {
            let m = mtcal_domain::machines::NewMachine {
                name: name.unwrap_or_else(|| id.clone()),
                id,
                topology: None,
                travel_mm: travel.into_iter().collect(),
                site,
                tags,
            };
            let m = rt.block_on(async {
                let store = open(&db.db, false).await?;
                let m = mtcal_domain::machines::create(store.as_ref(), m)
                    .await
                    .map_err(refused)?;
                let what = ("machine.create", m.id.as_str(), Some(m.id.as_str()));
                audit(store.as_ref(), what, None, &m).await?;
                anyhow::Ok(m)
            })?;
            super::out::noteln!("registered machine {} ({})", m.id, m.name);
        }
        Command::CreateProfile {
            db,
            scope,
            target,
            limits,
        } => {
            let text = match limits.strip_prefix('@') {
                Some(file) => std::fs::read_to_string(file)
                    .map_err(|e| super::BadInput(format!("--limits @{file}: {e}")))?,
                None => limits,
            };
            let limits = serde_json::from_str(&text)
                .map_err(|e| super::BadInput(format!("--limits: {e}")))?;
            let p = mtcal_domain::profiles::NewProfile {
                scope,
                target,
                limits,
                webhook_url: None,
                webhook_secret: None,
            };
            let (profile, refreshed) = rt.block_on(async {
                let store = open(&db.db, false).await?;
                let policy = mtcal_domain::webhooks::TargetPolicy::default();
                let profile = mtcal_domain::profiles::create(store.as_ref(), &p, &policy)
                    .await
                    .map_err(refused)?;
                let seen = mtcal_domain::profiles::audited(&profile);
                let machine = mtcal_domain::profiles::machine_of(&profile);
                let what = ("profile.create", profile.id.as_str(), machine);
                audit(store.as_ref(), what, None, &seen).await?;
                let n = mtcal_domain::fleet::refresh_profile_targets(
                    store.as_ref(),
                    &profile.scope,
                    &profile.target,
                )
                .await?;
                anyhow::Ok((profile, n))
            })?;
            super::out::noteln!(
                "created tolerance profile {} ({} {}); verdicts of {refreshed} machine(s) refreshed",
                profile.id,
                profile.scope,
                profile.target
            );
            super::out::outln!("{}", profile.id)?;
        }
        Command::RevokeKey { db, id } => {
            let key = rt.block_on(async {
                let store = open(&db.db, false).await?;
                let before = store.list_keys().await?.into_iter().find(|k| k.id == id);
                let key = match store.revoke_key(&id).await {
                    Err(mtcal_store::StoreError::NotFound(_)) => {
                        return Err(super::BadInput(format!(
                            "no key {id} in {} (see `mtcal admin list-keys`)",
                            db.db
                        ))
                        .into());
                    }
                    other => other?,
                };
                let what = ("key.revoke", key.id.as_str(), None);
                audit(store.as_ref(), what, before.as_ref(), &key).await?;
                anyhow::Ok(key)
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
