//! `mtcal submit` (the CLI's client of the service) against a running service.

use crate::common::*;
use mtcal_client::ClientError;
use serde_json::Value;
use std::process::{Command, Output};

/// `mtcal submit DIR --machine M --url … --key …` plus `extra`, run off the async threads
/// (the service runs in this process).
async fn submit(app: &App, dir: &std::path::Path, machine: &str, extra: &[&str]) -> Output {
    let mut args: Vec<String> = vec![
        "submit".into(),
        dir.display().to_string(),
        "--machine".into(),
        machine.into(),
        "--url".into(),
        app.url.clone(),
        "--key".into(),
        app.write_key.clone(),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    tokio::task::spawn_blocking(move || Command::new(BIN).args(args).output().unwrap())
        .await
        .unwrap()
}

#[tokio::test]
async fn submit_uploads_identifies_and_prints_the_result() {
    let app = spawn_app().await;
    app.machine("VMC-1").await;
    let dir = app.path("s");
    write_session(&dir, "VMC-1", 2, 1);
    let out = submit(&app, &dir, "VMC-1", &["--json"]).await;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    let stored = app.client.latest("VMC-1", None).await.unwrap();
    assert_eq!(doc, stored.document);

    // A machine the service does not know: its refusal, with its message.
    let out = submit(&app, &dir, "VMC-2", &[]).await;
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("machine VMC-2 not found"), "{err}");
    // A folder the reader refuses never reaches the service: exit code 2.
    std::fs::write(dir.join("stray.csv"), "a,b\n1,2\n").unwrap();
    let before = app.counts().await;
    let out = submit(&app, &dir, "VMC-1", &[]).await;
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("stray.csv: uploaded file is not referenced"),
        "{err}"
    );
    assert_eq!(app.counts().await, before);
}

/// `admin create-key` on a database file that does not exist is refused (a typo in --db
/// would otherwise make a new empty database whose keys the service never sees), unless
/// `--create` says so.
#[test]
fn create_key_refuses_a_missing_database_unless_told_to_create_it() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("typo.sqlite");
    let run = |extra: &[&str]| {
        Command::new(BIN)
            .args(["admin", "create-key", "--db", db.to_str().unwrap()])
            .args(extra)
            .env_remove("MTCAL_DB")
            .output()
            .unwrap()
    };
    let out = run(&[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no such database"), "{err}");
    assert!(!db.exists());
    let out = run(&["--create"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("mtk_"));
    assert!(run(&[]).status.success(), "the file exists now");
}

/// `admin list-keys` shows every key without its secret; `admin revoke-key` revokes one
/// (the list then shows when) and names an unknown id as such.
#[test]
fn admin_lists_and_revokes_keys() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("k.sqlite");
    let db = db.to_str().unwrap();
    let secret = mtcal(&[
        "admin",
        "create-key",
        "--db",
        db,
        "--create",
        "--label",
        "line 1",
    ]);
    let listed: serde_json::Value =
        serde_json::from_str(&mtcal(&["admin", "list-keys", "--db", db, "--json"])).unwrap();
    let keys = listed.as_array().unwrap();
    assert_eq!(keys.len(), 1);
    assert_eq!(keys[0]["label"], "line 1");
    assert!(keys[0]["revoked_at"].is_null());
    let id = keys[0]["id"].as_str().unwrap();
    let table = mtcal(&["admin", "list-keys", "--db", db]);
    assert!(
        table.contains(id) && !table.contains(secret.trim()),
        "{table}"
    );
    mtcal(&["admin", "revoke-key", "--db", db, id]);
    let listed: serde_json::Value =
        serde_json::from_str(&mtcal(&["admin", "list-keys", "--db", db, "--json"])).unwrap();
    assert!(listed[0]["revoked_at"].is_string(), "{listed}");
    let out = Command::new(BIN)
        .args(["admin", "revoke-key", "--db", db, "key_nope"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no key key_nope"), "{err}");
    // Both changes are in the audit trail, as the API's key routes record them, through
    // `cli`; revoking the revoked key again records nothing.
    mtcal(&["admin", "revoke-key", "--db", db, id]);
    let events = tokio::runtime::Runtime::new().unwrap().block_on(async {
        let store = mtcal_store::open(db).await.unwrap();
        let q = mtcal_store::AuditQuery {
            limit: 100,
            ..Default::default()
        };
        store.list_audit(&q).await.unwrap()
    });
    let got: Vec<(&str, &str)> = events
        .iter()
        .map(|e| (e.event.action.as_str(), e.event.target.as_str()))
        .collect();
    assert_eq!(
        got,
        [("key.revoke", id), ("key.create", id)],
        "newest first"
    );
    for e in &events {
        let x = &e.event;
        assert_eq!((x.actor.as_str(), x.via.as_str()), ("cli", "cli"));
        assert!(!x.actor_name.is_empty() && x.client.is_none(), "{x:?}");
        assert!(x.after.as_ref().unwrap()["label"] == "line 1", "{x:?}");
        assert!(
            !x.after
                .as_ref()
                .unwrap()
                .to_string()
                .contains(secret.trim())
        );
    }
    let revoke = &events[0].event;
    assert!(revoke.before.as_ref().unwrap()["revoked_at"].is_null());
    assert!(revoke.after.as_ref().unwrap()["revoked_at"].is_string());
    assert!(events[1].event.before.is_none());
}

/// `admin create-machine` and `admin create-profile` apply the API's rules on the
/// database: a bad field is refused with exit code 2 and a message naming it, and
/// nothing is stored; what they create is what the API then serves.
#[tokio::test]
async fn admin_creates_machines_and_profiles_with_the_apis_rules() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("m.sqlite");
    let db = db.to_str().unwrap();
    mtcal(&["admin", "create-key", "--db", db, "--create"]);
    let refused = |args: &[&str], says: &str| {
        let out = Command::new(BIN).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    };
    refused(
        &[
            "admin",
            "create-machine",
            "--db",
            db,
            "VMC-1",
            "--travel",
            "X=300:-300",
        ],
        "travel_mm.X",
    );
    refused(
        &[
            "admin",
            "create-machine",
            "--db",
            db,
            "VMC-1",
            "--travel",
            "X=-300",
        ],
        "AXIS=MIN:MAX",
    );
    refused(&["admin", "create-machine", "--db", db, "bad id"], "id");
    mtcal(&[
        "admin",
        "create-machine",
        "--db",
        db,
        "VMC-1",
        "--name",
        "Line 1 VMC",
        "--site",
        "north",
        "--tag",
        "vmc",
        "--travel",
        "X=-300:300",
        "--travel",
        "Y=-200:200",
    ]);
    refused(&["admin", "create-machine", "--db", db, "VMC-1"], "VMC-1");
    refused(
        &[
            "admin",
            "create-profile",
            "--db",
            db,
            "--scope",
            "tag",
            "--target",
            "vmc",
            "--limits",
            r#"{"terms": {"EQX": 5}}"#,
        ],
        "EQX",
    );
    refused(
        &[
            "admin",
            "create-profile",
            "--db",
            db,
            "--scope",
            "machine",
            "--target",
            "VMC-2",
            "--limits",
            r#"{"drift_um": 1}"#,
        ],
        "VMC-2",
    );
    let limits = dir.path().join("limits.json");
    std::fs::write(
        &limits,
        r#"{"terms": {"EXX": {"range": 10, "per_length_mm": 300}}, "squareness": {"EC0Y": 30}}"#,
    )
    .unwrap();
    let id = mtcal(&[
        "admin",
        "create-profile",
        "--db",
        db,
        "--scope",
        "tag",
        "--target",
        "vmc",
        "--limits",
        &format!("@{}", limits.display()),
    ]);
    let store = mtcal_store::open(db).await.unwrap();
    let m = store.get_machine("VMC-1").await.unwrap();
    assert_eq!(
        (m.name.as_str(), m.site.as_deref()),
        ("Line 1 VMC", Some("north"))
    );
    assert_eq!(m.travel_mm["Y"], [-200.0, 200.0]);
    let profiles = store.list_tolerances().await.unwrap();
    assert_eq!(profiles.len(), 1, "the refused profiles stored nothing");
    assert_eq!(profiles[0].id, id.trim());
    assert_eq!(profiles[0].limits["squareness"]["EC0Y"], 30.0);
    // Both are in the audit trail as the API's routes record them, through `cli`; the
    // refused ones recorded nothing (after the key's own event).
    let q = mtcal_store::AuditQuery {
        limit: 100,
        ..Default::default()
    };
    let events = store.list_audit(&q).await.unwrap();
    let got: Vec<_> = events
        .iter()
        .map(|e| (e.event.action.as_str(), e.event.target.as_str()))
        .collect();
    let want = [
        ("profile.create", id.trim()),
        ("machine.create", "VMC-1"),
        ("key.create", events[2].event.target.as_str()),
    ];
    assert_eq!(got, want, "newest first");
    let (profile, machine) = (&events[0].event, &events[1].event);
    for x in [profile, machine] {
        assert_eq!((x.actor.as_str(), x.via.as_str()), ("cli", "cli"));
        assert!(x.before.is_none() && x.client.is_none(), "{x:?}");
    }
    assert_eq!(machine.machine_id.as_deref(), Some("VMC-1"));
    assert_eq!(machine.after, Some(serde_json::to_value(&m).unwrap()));
    assert_eq!(profile.machine_id, None, "a tag's profile");
    let after = profile.after.as_ref().unwrap();
    assert_eq!(after["target"], "vmc");
    assert_eq!(after["limits"]["squareness"]["EC0Y"], 30.0);
}

/// The command lines of the deployment examples (`deploy/`) are ones `mtcal` accepts:
/// each is run with `--help` appended, which succeeds only when every argument before it
/// is known (so a renamed flag breaks this test, not a plant's service).
#[test]
fn deployment_examples_use_flags_mtcal_accepts() {
    let root = env!("CARGO_MANIFEST_DIR");
    let unit = std::fs::read_to_string(format!("{root}/deploy/mtcal.service")).unwrap();
    let image = std::fs::read_to_string(format!("{root}/deploy/Containerfile")).unwrap();
    let mut lines: Vec<Vec<String>> = Vec::new();
    let words = |s: &str| s.split_whitespace().map(str::to_string).collect::<Vec<_>>();
    for l in unit.lines().chain(image.lines()) {
        let l = l.trim_start_matches('#').trim();
        if let Some(cmd) = l.strip_prefix("ExecStart=/usr/local/bin/mtcal ") {
            lines.push(words(cmd));
        } else if let Some(cmd) = l.split_once("/usr/local/bin/mtcal ").map(|(_, c)| c) {
            lines.push(words(cmd));
        } else if let Some(rest) = l.split_once(" mtcal ").map(|(_, c)| c) {
            if rest.starts_with("serve") || rest.starts_with("worker") || rest.starts_with("admin")
            {
                lines.push(words(rest));
            }
        } else if let Some(cmd) = l.strip_prefix("CMD ") {
            let v: Vec<String> = serde_json::from_str(cmd).unwrap();
            lines.push(v);
        }
    }
    assert!(lines.len() >= 5, "{lines:?}");
    // Both set the sign-in cookies' key (docs/operations.md, "Operations").
    for (name, text) in [("mtcal.service", &unit), ("Containerfile", &image)] {
        assert!(
            text.contains("MTCAL_SESSION_KEY"),
            "{name} sets no MTCAL_SESSION_KEY"
        );
        assert!(text.contains("MTCAL_DB_POOL"), "{name} sizes no pool");
    }
    for args in lines {
        let out = Command::new(BIN)
            .args(&args)
            .arg("--help")
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "mtcal {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// A database URL is never printed with its password: not when a worker or the service
/// starts, not in the error when the database cannot be reached or the URL is refused.
#[test]
fn database_passwords_are_never_printed() {
    let secret = "S3cretPw";
    let pg = format!("postgres://mtcal:{secret}@127.0.0.1:1/mtcal?password={secret}");
    let other = format!("mysql://root:{secret}@127.0.0.1:1/db");
    let runs: Vec<Vec<&str>> = vec![
        vec!["worker", "--db", &pg, "--db-timeout-ms", "300"],
        vec![
            "serve",
            "--db",
            &pg,
            "--db-timeout-ms",
            "300",
            "--listen",
            "127.0.0.1:0",
        ],
        vec!["admin", "list-keys", "--db", &pg],
        vec!["worker", "--db", &other],
    ];
    for args in runs {
        let out = Command::new(BIN).args(&args).output().unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(!out.status.success(), "{args:?}: {text}");
        assert!(
            !text.contains(secret),
            "{args:?} printed the password:\n{text}"
        );
        assert!(
            text.contains(":***@127.0.0.1"),
            "{args:?} names no database:\n{text}"
        );
    }
}

/// Runs `mtcal ARGS` with its stdout a pipe whose reading end is closed before the
/// program writes anything (as `mtcal … | head` once head has what it wants, or a
/// reader that never reads); its exit status and stderr.
fn with_stdout_closed(args: &[&std::ffi::OsStr]) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(BIN)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    (
        out.status,
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Every command that prints ends quietly when its stdout is closed (exit 0, no panic,
/// no error): results as JSON and as summaries, a simulation's summary, the keys of
/// `admin` (`src/cli/out.rs`).
#[test]
fn commands_end_quietly_when_stdout_is_closed() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).into_os_string();
    let session = p("s");
    write_session(std::path::Path::new(&session), "VMC-P", 1, 0);
    let db = p("k.sqlite");
    let runs: Vec<Vec<std::ffi::OsString>> = vec![
        vec!["identify".into(), "--json".into(), session.clone()],
        vec!["identify".into(), session.clone()],
        vec!["standards".into(), session.clone()],
        vec![
            "simulate".into(),
            "--out".into(),
            p("sim"),
            "--plan".into(),
            "seed".into(),
        ],
        vec![
            "admin".into(),
            "create-key".into(),
            "--db".into(),
            db.clone(),
            "--create".into(),
        ],
        vec![
            "admin".into(),
            "list-keys".into(),
            "--db".into(),
            db.clone(),
        ],
    ];
    for args in runs {
        let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_os_str()).collect();
        let (status, err) = with_stdout_closed(&args);
        assert!(
            status.success() && !err.contains("panicked") && !err.contains("error:"),
            "mtcal {args:?}: {status:?}: {err}"
        );
    }
    // The work before the output was done: the simulation's files, the key.
    assert!(dir.path().join("sim/session.json").exists());
    let listed = mtcal(&["admin", "list-keys", "--db", db.to_str().unwrap(), "--json"]);
    assert_eq!(
        serde_json::from_str::<Value>(&listed)
            .unwrap()
            .as_array()
            .unwrap()
            .len(),
        1
    );
}

/// Runs `mtcal ARGS` with its stderr a pipe whose reading end is closed before the
/// program writes anything (a log reader that went away); its exit status and stdout.
fn with_stderr_closed(args: &[&std::ffi::OsStr]) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(BIN)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take());
    let out = child.wait_with_output().unwrap();
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// No output to a closed stderr can panic (`src/cli/out.rs`): a command's notes and its
/// error message are lost, its work, its stdout and its exit code stay (0; 2 for bad
/// input; 1 otherwise), never a panic's 101.
#[test]
fn commands_keep_their_exit_code_when_stderr_is_closed() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).into_os_string();
    let session = p("s");
    write_session(std::path::Path::new(&session), "VMC-P", 1, 0);
    let db = p("k.sqlite");
    let runs: Vec<(Vec<std::ffi::OsString>, i32)> = vec![
        // Success, a note on stderr (the key's line) and the secret on stdout.
        (
            vec![
                "admin".into(),
                "create-key".into(),
                "--db".into(),
                db.clone(),
                "--create".into(),
            ],
            0,
        ),
        (vec!["identify".into(), "--json".into(), session.clone()], 0),
        // Failures: the error message is a note on stderr. Bad input (2): an unknown key.
        (
            vec![
                "admin".into(),
                "revoke-key".into(),
                "--db".into(),
                db.clone(),
                "no-such-key".into(),
            ],
            2,
        ),
        // Any other failure (1): a database in a folder that does not exist.
        (
            vec![
                "admin".into(),
                "create-key".into(),
                "--db".into(),
                p("no-such-folder/k.sqlite"),
                "--create".into(),
            ],
            1,
        ),
    ];
    for (args, code) in runs {
        let args: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_os_str()).collect();
        // The same command with stderr open gives the code this test expects.
        let open = Command::new(BIN).args(&args).output().unwrap();
        assert_eq!(
            open.status.code(),
            Some(code),
            "mtcal {args:?} (stderr open)"
        );
        let (status, stdout) = with_stderr_closed(&args);
        assert_eq!(status.code(), Some(code), "mtcal {args:?}: {status:?}");
        assert_eq!(stdout.is_empty(), open.stdout.is_empty(), "mtcal {args:?}");
    }
}

/// `mtcal serve` with its stdout closed keeps serving (its announcement is dropped; its
/// work is answering requests), and stops cleanly on SIGTERM.
#[tokio::test]
async fn serve_keeps_serving_when_stdout_is_closed() {
    let dir = tempfile::tempdir().unwrap();
    let addr = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let mut child = Command::new(BIN)
        .args([
            "serve",
            "--no-worker",
            "--listen",
            &addr.to_string(),
            "--db",
        ])
        .arg(dir.path().join("svc.sqlite"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let client = mtcal_client::Client::new(&format!("http://{addr}"), "");
    let mut healthy = false;
    for _ in 0..200 {
        if client.health().await.is_ok() {
            healthy = true;
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
    let _ = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(healthy, "the service did not answer: {err}");
    assert!(
        out.status.success() && !err.contains("panicked"),
        "{:?}: {err}",
        out.status
    );
}

/// A plane file with a finite but absurd deviation (1e308 µm) is refused at its cell
/// instead of giving NaN figures.
#[test]
fn identify_refuses_absurd_magnitudes() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("s");
    write_session(&session, "VMC-P", 1, 0);
    let csv = set_plane_cell(&session, "du_um", 4, "1e308");
    let out = Command::new(BIN)
        .arg("identify")
        .arg(&session)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    let name = csv.file_name().unwrap().to_string_lossy();
    assert!(
        err.contains(&format!("{name}:4:du_um")) && err.contains("plausible deviation"),
        "{err}"
    );
}

/// `mtcal demo` on an address already in use says so and how to pick a free port, and
/// leaves no temporary folder behind.
#[test]
fn demo_on_a_taken_address_says_so() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap().to_string();
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new(BIN)
        .args(["demo", "--no-browser", "--exit", "--listen", &addr])
        .env("TMPDIR", tmp.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--listen 127.0.0.1:0"), "{err}");
    assert!(err.contains("already in use"), "the system's reason: {err}");
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// A path that does not exist is named in full with the system's reason, with exit code
/// 2 (bad input), for every command that reads an input: a dataset (session folder or
/// file) or a result document; no message carries a `:0:` place it is not tied to.
#[test]
fn a_missing_path_is_named_with_the_reason() {
    let missing = "/no/such/dir";
    let commands: [&[&str]; 9] = [
        &["identify", missing],
        &["diagnose", missing],
        &["standards", missing],
        &["cradle", missing],
        &["export", missing, "--format", "csv"],
        &["report", missing],
        &["compare", missing, missing],
        &["sensitivity", missing],
        &[
            "sensitivity",
            "--template",
            "vmc3",
            "--identification",
            missing,
        ],
    ];
    for args in commands {
        let out = Command::new(BIN).args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("{missing}: cannot read"))
                && err.contains("No such file or directory"),
            "{args:?}: {err}"
        );
        assert!(!err.contains(":0:"), "{args:?}: {err}");
    }
}

/// A session whose plane file has its positions written in micrometres (a line pass at
/// 480 mm/min moving 1000× faster) is refused by `mtcal identify` with the message the
/// service gives for the same files (one reader): the file, the columns and what to
/// change; exit code 2, nothing identified.
#[tokio::test]
async fn positions_in_micrometres_are_refused_by_the_cli_as_by_the_service() {
    let app = spawn_app().await;
    app.machine("VMC-U").await;
    let session = app.path("s");
    write_session(&session, "VMC-U", 1, 0);
    let name = csv_names(&session)[0].clone();
    let csv = session.join(&name);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let scaled: Vec<usize> = ["x_mm", "y_mm", "z_mm"]
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    let mut out = header.join(",") + "\n";
    for line in lines {
        let cells: Vec<String> = line
            .split(',')
            .enumerate()
            .map(|(k, c)| match scaled.contains(&k) {
                true => format!("{}", c.parse::<f64>().unwrap() * 1000.0),
                false => c.to_string(),
            })
            .collect();
        out += &(cells.join(",") + "\n");
    }
    std::fs::write(&csv, out).unwrap();
    let ran = {
        let session = session.clone();
        tokio::task::spawn_blocking(move || {
            Command::new(BIN)
                .arg("identify")
                .arg(&session)
                .output()
                .unwrap()
        })
        .await
        .unwrap()
    };
    assert_eq!(ran.status.code(), Some(2));
    assert!(ran.stdout.is_empty(), "nothing identified");
    let err = String::from_utf8_lossy(&ran.stderr);
    // The file, the position column that moves most, the rule.
    let line = err
        .lines()
        .find(|l| l.contains("positions move at"))
        .unwrap_or_else(|| panic!("{err}"));
    let expected = line
        .split(" the positions")
        .next()
        .unwrap()
        .trim_start_matches("error: ");
    assert!(
        [
            format!("{name}: x_mm:"),
            format!("{name}: y_mm:"),
            format!("{name}: z_mm:")
        ]
        .contains(&expected.to_string())
            && line.contains("divide x_mm, y_mm and z_mm by 1000"),
        "{err}"
    );
    // The service, sent the same files as they are, refuses them with the same words.
    let e = app
        .client
        .upload_files("VMC-U", &folder_files(&session))
        .await
        .unwrap_err();
    assert_eq!(e.code(), Some("invalid_dataset"), "{e}");
    let ClientError::Api { message, .. } = &e else {
        panic!("{e}")
    };
    assert!(
        message.contains(expected) && message.contains("divide x_mm, y_mm and z_mm by 1000"),
        "{message}"
    );
}

/// `mtcal submit` with a key that may only read gets the service's refusal (403, the
/// scope needed), not the broken pipe of the upload the service cut short; exit code 1
/// (the input is fine, the service refused it).
#[tokio::test]
async fn submit_with_a_read_key_reports_the_refusal() {
    let app = spawn_app().await;
    app.machine("VMC-1").await;
    let dir = app.path("s");
    write_session(&dir, "VMC-1", 2, 1);
    let args: Vec<String> = vec![
        "submit".into(),
        dir.display().to_string(),
        "--machine".into(),
        "VMC-1".into(),
        "--url".into(),
        app.url.clone(),
        "--key".into(),
        app.read_key.clone(),
    ];
    let before = app.counts().await;
    let out = tokio::task::spawn_blocking(move || Command::new(BIN).args(args).output().unwrap())
        .await
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("403") && err.contains("needs a key with scope write"),
        "{err}"
    );
    assert!(!err.to_lowercase().contains("broken pipe"), "{err}");
    assert_eq!(app.counts().await, before, "nothing stored");
}

/// Option values out of their range get the command's own message, exit code 2: a
/// negative number is a value (`--noise-um -1`), not an unexpected argument.
#[test]
fn option_values_out_of_range_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("s");
    let run = |extra: &[&str]| {
        Command::new(BIN)
            .args(["simulate", "--out", out_dir.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap()
    };
    let out = run(&["--noise-um", "-1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--noise-um -1: the noise is a standard deviation"),
        "{err}"
    );
    assert!(!err.contains("unexpected argument"), "{err}");
    assert!(!out_dir.exists(), "nothing written");
    // A flag is still a flag: an unknown one is refused by the parser.
    let out = run(&["--no-such-flag"]);
    assert_eq!(out.status.code(), Some(2));
}

/// The effects `--effect` refuses a wrong name with are the names its help lists, and
/// the other way round: every name the simulator accepts.
#[test]
fn the_effect_error_lists_the_names_the_help_lists() {
    let help = Command::new(BIN)
        .args(["simulate", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout).replace('\n', " ");
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(BIN)
        .args(["simulate", "--out"])
        .arg(dir.path().join("s"))
        .args(["--effect", "wobble"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    let listed = err
        .split("expected one of ")
        .nth(1)
        .and_then(|r| r.split(')').next())
        .unwrap_or_else(|| panic!("{err}"));
    let names: Vec<&str> = listed.split(", ").collect();
    assert_eq!(names, mtcal_solver::simulate::effects::EFFECT_NAMES);
    let in_help = help
        .split("Names: ")
        .nth(1)
        .unwrap_or_else(|| panic!("{help}"));
    let in_help: Vec<String> = in_help
        .split(", ")
        .take(names.len())
        .map(|n| n.split_whitespace().next().unwrap_or("").to_string())
        .collect();
    assert_eq!(in_help, names, "{help}");
}

/// The summaries print figures with digits that suit them (`condition number 214.2`), and
/// units as a person writes them (µm, µrad; never `um`).
#[test]
fn identify_prints_sensible_digits_and_units() {
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("s");
    write_session(&session, "VMC-D", 1, 0);
    let text = mtcal(&["identify", session.to_str().unwrap()]);
    let condition = text
        .split("condition number ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .unwrap_or_else(|| panic!("{text}"));
    let value: f64 = condition.parse().unwrap_or_else(|_| panic!("{condition}"));
    assert!(value > 1.0, "{condition}");
    assert!(
        condition == mtcal_views::pages::num(value) && condition.len() <= 8,
        "{condition}"
    );
    assert!(text.contains(" µm ") && text.contains(" µrad "), "{text}");
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        assert!(!words.contains(&"um") && !words.contains(&"urad"), "{line}");
    }
}

/// `mtcal demo` without --db works in a temporary folder and deletes it when it stops on
/// Ctrl-C (SIGINT), the way a user ends it.
#[test]
fn demo_deletes_its_temporary_folder_on_ctrl_c() {
    use std::io::BufRead;
    let tmp = tempfile::tempdir().unwrap();
    let mut child = Command::new(BIN)
        .args(["demo", "--no-browser", "--listen", "127.0.0.1:0"])
        .args(["--machines", "1", "--checks", "1"])
        .env("TMPDIR", tmp.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    let mut database = String::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        if line.starts_with("database:") {
            database = line.clone();
        }
        if line.starts_with("serving") {
            break;
        }
    }
    assert!(database.contains("temporary"), "{database}");
    let folders: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
    assert_eq!(folders.len(), 1, "the demo's folder while it runs");
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    assert!(child.wait().unwrap().success());
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}
