//! Uploads: a session folder identified through the service gives the CLI's result; the
//! raw files come back unchanged; archives; the service and the CLI accept and refuse the
//! same folders; refused uploads store nothing.

use crate::common::*;
use mtcal_store::JobState;
use reqwest::multipart::{Form, Part};
use reqwest::{Method, StatusCode};
use serde_json::Value;

#[tokio::test]
async fn upload_identify_gives_the_result_of_the_cli() {
    let app = spawn_app().await;
    app.machine("VMC-1").await;
    let dir = app.path("s");
    write_session(&dir, "VMC-1", 7, 0);

    let ds = app.client.upload_path("VMC-1", &dir).await.unwrap();
    let csvs = csv_names(&dir);
    assert_eq!(ds.files.len(), csvs.len() + 1);
    let job = app.identify(&ds.id).await;
    let done = app.wait(&job, JobState::Succeeded).await;
    assert_eq!((done.progress, done.attempts), (1.0, 1));
    let doc = app.client.job_result(&job).await.unwrap();

    // The CLI on the same folder gives the identical document (same reader, solver and
    // default options; documents are stored and returned with exact doubles).
    let cli: Value =
        serde_json::from_str(&mtcal(&["identify", dir.to_str().unwrap(), "--json"])).unwrap();
    assert_eq!(doc, cli);
    // Sanity of the result against the truth of the generator: residual at noise level
    // (σ = 0.1 µm per component; thousands of samples give the RMS within a few per cent).
    let rms = doc["fit"]["residual_rms_um"].as_f64().unwrap();
    assert!((0.08..0.13).contains(&rms), "residual {rms}");

    // Raw files come back unchanged, with their checksum.
    let first = &csvs[0];
    let raw = std::fs::read(dir.join(first)).unwrap();
    let (_, resp) = app
        .client
        .send_raw(app.client.request(
            Method::GET,
            &format!("/api/v1/datasets/{}/files/{first}", ds.id),
        ))
        .await
        .unwrap();
    let sum = resp.headers()["x-checksum-sha256"]
        .to_str()
        .unwrap()
        .to_string();
    assert_eq!(resp.bytes().await.unwrap().as_ref(), raw.as_slice());
    let meta = ds.files.iter().find(|f| &f.name == first).unwrap();
    assert_eq!(meta.sha256, sum);
    assert_eq!(app.client.dataset_file(&ds.id, first).await.unwrap(), raw);

    // The same session as one .tar.gz (files inside a folder) is the same dataset: the
    // same manifest checksum, so the repeated upload is refused with a pointer to the
    // first (a second copy would count the check twice in every trend).
    let mut tar = tar::Builder::new(flate2::write::GzEncoder::new(
        Vec::new(),
        flate2::Compression::fast(),
    ));
    tar.append_dir_all("session", &dir).unwrap();
    let gz = tar.into_inner().unwrap().finish().unwrap();
    let again = app.client.upload_archive("VMC-1", gz, true).await;
    let msg = refusal_message(again);
    assert!(
        msg.contains(&format!("identical to dataset {}", ds.id)),
        "{msg}"
    );
    assert_eq!(app.counts().await.datasets, 1);
}

/// The service and the CLI read uploads with one reader: a `simulate` folder (with its
/// truth.json) is accepted by both, the extra file not stored; a `.gz` name over plain
/// content and a forgotten plane file are refused by both with the same message.
#[tokio::test]
async fn service_and_cli_accept_and_refuse_the_same_folders() {
    let app = spawn_app().await;
    app.machine("SIM-0001").await;
    let dir = app.path("sim");
    mtcal(&[
        "simulate",
        "--out",
        dir.to_str().unwrap(),
        "--plan",
        "seed",
        "--seed",
        "3",
    ]);
    assert!(dir.join("truth.json").is_file());
    // The whole folder as multipart and as a .tar.gz.
    let ds = app
        .client
        .upload_files("SIM-0001", &folder_files(&dir))
        .await
        .unwrap();
    assert!(ds.files.iter().all(|f| f.name != "truth.json"), "{ds:?}");
    let mut tar = tar::Builder::new(flate2::write::GzEncoder::new(
        Vec::new(),
        flate2::Compression::fast(),
    ));
    tar.append_dir_all("sim", &dir).unwrap();
    let gz = tar.into_inner().unwrap().finish().unwrap();
    let msg = refusal_message(app.client.upload_archive("SIM-0001", gz, true).await);
    assert!(
        msg.contains(&format!("identical to dataset {}", ds.id)),
        "{msg}"
    );
    mtcal(&["identify", dir.to_str().unwrap()]);

    // Two broken variants of the folder: the CLI's error is the service's message.
    let plane = csv_names(&dir)[0].clone();
    let plain = std::fs::read(dir.join(&plane)).unwrap();
    type Breaker<'a> = Box<dyn Fn(&std::path::Path) + 'a>;
    let breakers: [(&str, Breaker); 2] = [
        (
            "a .gz name over plain content",
            Box::new(|d| {
                std::fs::remove_file(d.join(&plane)).unwrap();
                std::fs::write(d.join(format!("{plane}.gz")), &plain).unwrap();
            }),
        ),
        (
            "a plane file session.json does not list",
            Box::new(|d| std::fs::write(d.join("extra.csv"), &plain).unwrap()),
        ),
    ];
    for (what, breaker) in breakers {
        let bad = app.path(&format!("bad-{}", what.len()));
        std::fs::create_dir(&bad).unwrap();
        for (n, b) in folder_files(&dir) {
            std::fs::write(bad.join(n), b).unwrap();
        }
        breaker(&bad);
        let before = app.counts().await;
        let r = app
            .client
            .upload_files("SIM-0001", &folder_files(&bad))
            .await;
        let message = refusal_message(r);
        let out = std::process::Command::new(BIN)
            .args(["identify", bad.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(!out.status.success(), "{what}: the CLI accepted it");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains(&message),
            "{what}: CLI {stderr:?}, service {message:?}"
        );
        assert_eq!(app.counts().await, before, "{what}");
    }
}

#[tokio::test]
async fn refused_uploads_get_documented_errors_and_store_nothing() {
    let app0 = spawn_app().await;
    let dir = app0.path("s");
    write_session(&dir, "VMC-R", 4, 0);
    let size: usize = folder_files(&dir).iter().map(|(_, b)| b.len()).sum();
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        limits: mtcal_server::UploadLimits {
            max_bytes: size + 100_000,
            ..Default::default()
        },
        ..AppOptions::default()
    })
    .await;
    app.machine("VMC-R").await;
    let before = app.counts().await;

    // Corrupt upload: a non-number in a required column (du_um of data line 10).
    let csvs = csv_names(&dir);
    let bad_file = &csvs[1];
    let p = dir.join(bad_file);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header: Vec<&str> = lines[0].split(',').collect();
    let col = header.iter().position(|c| *c == "du_um").unwrap();
    let mut cells: Vec<String> = lines[10].split(',').map(String::from).collect();
    cells[col] = "abc".into();
    lines[10] = cells.join(",");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let r = app.client.upload_files("VMC-R", &folder_files(&dir)).await;
    let msg = refusal_message(r);
    assert!(msg.starts_with(&format!("{bad_file}:11:du_um:")), "{msg}");
    let r = app.client.upload_files("VMC-R", &folder_files(&dir)).await;
    assert_eq!(
        refused(r),
        (StatusCode::UNPROCESSABLE_ENTITY, "invalid_dataset".into())
    );

    // Oversize bodies: an upload over the configured limit (the session's size + 100 kB,
    // sent with a 200 kB extra file), and JSON over the 1 MiB limit of other routes.
    write_session(&dir, "VMC-R", 4, 0);
    let mut files = folder_files(&dir);
    files.push(("padding.txt".into(), vec![b'#'; 200_000]));
    let r = app.client.upload_files("VMC-R", &files).await;
    assert_eq!(
        refused(r),
        (StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large".into())
    );
    let big = mtcal_server::api::machines::NewMachine {
        id: "X3".into(),
        name: "x".repeat(2 << 20),
        topology: None,
        travel_mm: Default::default(),
        site: None,
        tags: vec![],
    };
    assert_eq!(
        refused(app.client.create_machine(&big).await),
        (StatusCode::PAYLOAD_TOO_LARGE, "payload_too_large".into())
    );
    // A session of another machine.
    let other = app.path("other");
    write_session(&other, "VMC-OTHER", 4, 0);
    let r = app.client.upload_path("VMC-R", &other).await;
    assert!(refusal_message(r).contains("machine_id \"VMC-OTHER\" does not match"));

    assert_eq!(
        app.counts().await,
        before,
        "a rejected request changed the database"
    );
}

/// More uploads at once than the process reads at once (`MAX_CONCURRENT_UPLOADS`): the
/// others wait for a slot, none is refused, each is stored once.
#[tokio::test]
async fn concurrent_uploads_beyond_the_limit_wait_and_all_succeed() {
    let app = spawn_app().await;
    app.machine("VMC-U").await;
    let n = 3 * mtcal_server::MAX_CONCURRENT_UPLOADS;
    let dirs: Vec<_> = (0..n)
        .map(|q| {
            let d = app.path(&format!("u{q}"));
            write_session(&d, "VMC-U", 9 + q as u64, 0);
            d
        })
        .collect();
    let mut set = tokio::task::JoinSet::new();
    for d in dirs {
        let c = app.client.clone();
        set.spawn(async move { c.upload_path("VMC-U", &d).await.map(|ds| ds.id) });
    }
    while let Some(done) = set.join_next().await {
        done.unwrap().unwrap();
    }
    assert_eq!(app.counts().await.datasets, n as i64);
}

/// A `.tar.gz` of a `mtcal simulate` folder made the way a user makes it
/// (`tar czf sim.tar.gz -C sim .`: entries `./session.json`, …, `./truth.json`) is
/// accepted on a fresh machine, truth.json ignored and not stored; archive entries that
/// are links or devices, or that leave the folder (`..`, an absolute path), are refused
/// with the entry named, and a gzip body that is not gzip is refused as the CLI refuses
/// a `.gz` name over plain content; none stores anything.
#[tokio::test]
async fn archives_of_simulate_folders_and_hostile_archives() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("SIM-0001").await;
    let dir = app.path("sim");
    mtcal(&[
        "simulate",
        "--out",
        dir.to_str().unwrap(),
        "--plan",
        "seed",
        "--seed",
        "5",
    ]);
    let tar_of = |entries: &mut dyn FnMut(&mut tar::Builder<Vec<u8>>)| {
        let mut b = tar::Builder::new(Vec::new());
        entries(&mut b);
        b.into_inner().unwrap()
    };
    let gz = |bytes: &[u8]| {
        use std::io::Write;
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(bytes).unwrap();
        e.finish().unwrap()
    };
    let plain = tar_of(&mut |b| b.append_dir_all(".", &dir).unwrap());
    let ds = app
        .client
        .upload_archive("SIM-0001", gz(&plain), true)
        .await
        .unwrap();
    assert_eq!(ds.kind, "session");
    assert!(ds.files.iter().any(|f| f.name == "session.json"));
    assert!(ds.files.iter().all(|f| f.name != "truth.json"), "{ds:?}");

    let before = app.counts().await;
    // Plain tar content sent as gzip.
    let msg = refusal_message(
        app.client
            .upload_archive("SIM-0001", plain.clone(), true)
            .await,
    );
    assert!(
        msg.contains("upload.tar.gz") && msg.contains("the content is not gzip"),
        "{msg}"
    );
    // A symbolic link, a hard link, a `..` path, an absolute path and devices beside the
    // session's files.
    let hostile = |kind: tar::EntryType, path: &str| {
        tar_of(&mut |b| {
            b.append_dir_all("sim", &dir).unwrap();
            let mut h = tar::Header::new_gnu();
            h.set_entry_type(kind);
            h.set_size(0);
            h.set_mode(0o644);
            h.set_link_name("/etc/passwd").unwrap();
            h.as_old_mut().name[..path.len()].copy_from_slice(path.as_bytes());
            h.set_cksum();
            b.append(&h, std::io::empty()).unwrap();
        })
    };
    for (kind, path, what) in [
        (
            tar::EntryType::Symlink,
            "sim/extra.csv",
            "is a symbolic link",
        ),
        (tar::EntryType::Link, "sim/hard.csv", "is a hard link"),
        (
            tar::EntryType::Regular,
            "sim/../../x.csv",
            "`..` are not allowed",
        ),
        (
            tar::EntryType::Regular,
            "/etc/session.json",
            "absolute paths",
        ),
        (tar::EntryType::Char, "sim/tty", "is a device"),
        (tar::EntryType::Block, "sim/disk", "is a device"),
    ] {
        let body = gz(&hostile(kind, path));
        let msg = refusal_message(app.client.upload_archive("SIM-0001", body, true).await);
        assert!(
            msg.contains(&format!("entry `{path}`")) && msg.contains(what),
            "{msg}"
        );
    }
    assert_eq!(app.counts().await, before);
}

/// A session saved by a spreadsheet (`;` separators, decimal commas, a byte-order mark):
/// refused without the dialect with what to change; with the form field
/// `csv_dialect=excel` (what `mtcal submit --csv-dialect excel` sends) it is stored as
/// sent and identified, giving the result of the plain folder; an unknown dialect is a
/// 400.
#[tokio::test]
async fn an_excel_session_is_read_in_the_excel_dialect() {
    let app = spawn_app().await;
    app.machine("VMC-X").await;
    let plain = app.path("plain");
    write_session(&plain, "VMC-X", 11, 0);
    let excel = app.path("excel");
    std::fs::create_dir(&excel).unwrap();
    for (name, bytes) in folder_files(&plain) {
        let bytes = if name.ends_with(".csv") {
            let text = String::from_utf8(bytes).unwrap();
            format!("\u{feff}{}", text.replace(',', ";").replace('.', ",")).into_bytes()
        } else {
            bytes
        };
        std::fs::write(excel.join(&name), bytes).unwrap();
    }
    let files = folder_files(&excel);
    let before = app.counts().await;
    let msg = refusal_message(app.client.upload_files("VMC-X", &files).await);
    assert!(
        msg.contains(".csv:1: the header is separated by `;`") && msg.contains("csv_dialect=excel"),
        "{msg}"
    );
    // An unknown dialect.
    let form = reqwest::multipart::Form::new()
        .text("csv_dialect", "lotus")
        .part(
            "files",
            reqwest::multipart::Part::bytes(files[0].1.clone()).file_name(files[0].0.clone()),
        );
    let r = app
        .client
        .send_raw(
            app.client
                .request(Method::POST, "/api/v1/machines/VMC-X/datasets")
                .multipart(form),
        )
        .await;
    assert_eq!(
        refused(r),
        (StatusCode::BAD_REQUEST, "invalid_request".into())
    );
    assert_eq!(app.counts().await, before);

    let ds = app
        .client
        .upload_path_in("VMC-X", &excel, mtcal_formats::CsvDialect::Excel)
        .await
        .unwrap();
    // Stored as sent.
    let first = &csv_names(&excel)[0];
    assert_eq!(
        app.client.dataset_file(&ds.id, first).await.unwrap(),
        std::fs::read(excel.join(first)).unwrap()
    );
    let job = app.identify(&ds.id).await;
    app.wait(&job, JobState::Succeeded).await;
    let doc = app.client.job_result(&job).await.unwrap();
    let cli: Value =
        serde_json::from_str(&mtcal(&["identify", plain.to_str().unwrap(), "--json"])).unwrap();
    assert_eq!(doc, cli);
    let cli_excel: Value = serde_json::from_str(&mtcal(&[
        "identify",
        excel.to_str().unwrap(),
        "--csv-dialect",
        "excel",
        "--json",
    ]))
    .unwrap();
    assert_eq!(cli_excel, cli);
}

/// Positions written in µm where mm are required, within the plausible bound but 1000×
/// the machine's registered travel, are refused naming the file and column (a slow test,
/// samples 100 s apart: its positions move at a plausible speed even read as mm).
#[tokio::test]
async fn positions_in_micrometres_are_refused_against_the_travel() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    app.machine("VMC-T").await;
    let json = r#"{"machine_id": "VMC-T", "measured_at": "2026-01-01T00:00:00Z",
      "planes": [{"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, 0]}]}"#;
    let mut csv = String::from("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n");
    for i in 0..=100 {
        let x_um = -50_000.0 + 1000.0 * i as f64;
        let noise = if i % 2 == 0 { 0.05 } else { -0.05 };
        csv += &format!(
            "1,{},{x_um},0,0,{},{}\n",
            i as f64 * 100.0,
            1.0 + noise,
            noise
        );
    }
    let files = vec![
        ("session.json".to_string(), json.as_bytes().to_vec()),
        ("xy.csv".to_string(), csv.into_bytes()),
    ];
    let (status, _) = refused(app.client.upload_files("VMC-T", &files).await);
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY);
    let msg = refusal_message(app.client.upload_files("VMC-T", &files).await);
    assert!(
        msg.starts_with("xy.csv: x_mm:") && msg.contains("divide the column by 1000"),
        "{msg}"
    );
    assert_eq!(app.counts().await.datasets, 0);
}

/// The archives a person makes of folder `dir/session`, named by the command that made
/// them: tar and zip, with the session at the top or in its folder.
fn archives_of(dir: &std::path::Path) -> Vec<(&'static str, std::path::PathBuf)> {
    let run = |cwd: &std::path::Path, program: &str, args: &[&str]| {
        let out = std::process::Command::new(program)
            .args(args)
            .current_dir(cwd)
            .output()
            .unwrap();
        assert!(out.status.success(), "{program} {args:?}: {out:?}");
    };
    run(dir, "tar", &["czf", "a.tgz", "-C", "session", "."]);
    run(dir, "tar", &["czf", "b.tar.gz", "session"]);
    run(dir, "zip", &["-qr", "c.zip", "session"]);
    run(&dir.join("session"), "zip", &["-qr", "../d.zip", "."]);
    vec![
        ("tar czf a.tgz -C session .", dir.join("a.tgz")),
        ("tar czf b.tar.gz session", dir.join("b.tar.gz")),
        ("zip -r c.zip session", dir.join("c.zip")),
        ("cd session && zip -r ../d.zip .", dir.join("d.zip")),
    ]
}

/// Each archive made with `tar` or `zip` is stored as the session it holds, with the
/// files of the folder as they are, whichever way it arrives: as a multipart file of the
/// API, as the request's body (`application/gzip` or `application/zip`, and
/// `application/octet-stream` read by its content) and through the dashboard's form.
#[tokio::test]
async fn archives_made_with_tar_and_zip_upload_by_every_path() {
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    let browser = app.sign_in(&app.write_key).await;
    let mut n = 0;
    for which in 0..4 {
        for path in ["multipart", "body", "octet-stream", "form"] {
            // A machine and a session of its own each: a machine's identical upload is a
            // 409.
            n += 1;
            let machine = format!("ARC-{n}");
            app.machine(&machine).await;
            let dir = app.path(&format!("up{n}"));
            std::fs::create_dir_all(dir.join("session")).unwrap();
            write_session(&dir.join("session"), &machine, 3, 0);
            let (what, archive) = archives_of(&dir).swap_remove(which);
            let bytes = std::fs::read(&archive).unwrap();
            let name = archive.file_name().unwrap().to_string_lossy().into_owned();
            let url = format!("/api/v1/machines/{machine}/datasets");
            let status = match path {
                "multipart" => {
                    let part = Part::bytes(bytes).file_name(name);
                    let rb = app
                        .client
                        .request(Method::POST, &url)
                        .multipart(Form::new().part("files", part));
                    app.client
                        .send_raw(rb)
                        .await
                        .unwrap_or_else(|e| panic!("{what} by {path}: {e}"))
                        .1
                        .status()
                }
                "body" | "octet-stream" => {
                    let ct = match (path, name.ends_with(".zip")) {
                        ("body", true) => "application/zip",
                        ("body", false) => "application/gzip",
                        _ => "application/octet-stream",
                    };
                    let rb = app
                        .client
                        .request(Method::POST, &url)
                        .header(reqwest::header::CONTENT_TYPE, ct)
                        .body(bytes);
                    app.client
                        .send_raw(rb)
                        .await
                        .unwrap_or_else(|e| panic!("{what} by {path}: {e}"))
                        .1
                        .status()
                }
                _ => {
                    let form = Form::new()
                        .text("csrf", browser.csrf.clone())
                        .part("files", Part::bytes(bytes).file_name(name))
                        .text("csv_dialect", "plain");
                    let r = browser
                        .post_multipart(&format!("/machines/{machine}/upload"), form)
                        .await;
                    assert_eq!(r.status(), StatusCode::SEE_OTHER, "{what} by the form");
                    StatusCode::CREATED
                }
            };
            assert_eq!(status, StatusCode::CREATED, "{what} by {path}");
            let datasets = app.client.datasets(&machine, false).await.unwrap();
            let [ds] = datasets.as_slice() else {
                panic!("{what} by {path}: {datasets:?}");
            };
            assert_eq!(ds.kind, "session", "{what} by {path}");
            let folder = folder_files(&dir.join("session"));
            let mut names: Vec<&str> = ds.files.iter().map(|f| f.name.as_str()).collect();
            names.sort();
            let want: Vec<&str> = folder.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(names, want, "{what} by {path}");
            for f in &ds.files {
                let raw = app.client.dataset_file(&ds.id, &f.name).await.unwrap();
                let (_, orig) = folder.iter().find(|(n, _)| *n == f.name).unwrap();
                assert_eq!(&raw, orig, "{what} by {path}: {} as in the folder", f.name);
            }
        }
    }
}

/// The upload examples of docs/api.md run as they stand (bash, curl, tar, zip) against
/// the service: each stores its dataset and answers it (201, JSON) with the kind and
/// samples of the files it sent.
#[tokio::test]
async fn the_upload_examples_of_the_api_document_run_as_written() {
    const SESSION: &str = r#"{"machine_id": "MACHINE", "measured_at": "2026-11-02T09:30:00Z",
      "planes": [{"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, -100]},
                 {"file": "xz.csv", "plane": "XZ", "head_offset_mm": [0, 0, -100]}]}"#;
    const PLANE: &str = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,0.2\n1,0.1,1,0,0,0.2,0.3\n2,0.2,0,0,0,0.0,0.0\n";
    // Saved by a spreadsheet: `;` separators, decimal commas, a byte-order mark.
    const RUNS: &str =
        "\u{feff}axis;run;direction;target_mm;deviation_um\nX;1;+;0;0,5\nX;1;+;10;0,7\n";
    let doc = include_str!("../../docs/api.md");
    let block = doc
        .split("Examples (`tests/e2e/uploads.rs` runs each")
        .nth(1)
        .and_then(|rest| rest.split("```sh\n").nth(1))
        .and_then(|rest| rest.split("```").next())
        .expect("docs/api.md holds the upload examples");
    // Each example: its comment line and the command after it.
    let mut examples: Vec<(String, String)> = vec![];
    for line in block.lines() {
        match line.strip_prefix("# ") {
            Some(what) => examples.push((what.to_string(), String::new())),
            None => examples.last_mut().expect("a comment first").1 += &format!("{line}\n"),
        }
    }
    assert_eq!(examples.len(), 4, "{block}");
    let app = spawn_app_with(AppOptions {
        run_worker: false,
        ..AppOptions::default()
    })
    .await;
    for (k, (what, script)) in examples.iter().enumerate() {
        let machine = format!("DOC-{k}");
        app.machine(&machine).await;
        let dir = app.path(&format!("doc{k}"));
        std::fs::create_dir_all(dir.join("session")).unwrap();
        std::fs::write(
            dir.join("session/session.json"),
            SESSION.replace("MACHINE", &machine),
        )
        .unwrap();
        for plane in ["xy.csv", "xz.csv"] {
            std::fs::write(dir.join("session").join(plane), PLANE).unwrap();
        }
        std::fs::write(dir.join("runs.csv"), RUNS).unwrap();
        let out = tokio::process::Command::new("bash")
            .args(["-euo", "pipefail", "-c", script])
            .current_dir(&dir)
            .env("MTCAL_URL", &app.url)
            .env("MTCAL_API_KEY", &app.write_key)
            .env("MACHINE", &machine)
            .output()
            .await
            .unwrap();
        assert!(
            out.status.success(),
            "{what}\n{script}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let ds: Value = serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|e| panic!("{what}: {e}: {}", String::from_utf8_lossy(&out.stdout)));
        let want = if what.starts_with("Positioning") {
            ("positioning", 2)
        } else {
            ("session", 6)
        };
        assert_eq!(
            (
                ds["kind"].as_str().unwrap(),
                ds["samples"].as_i64().unwrap()
            ),
            want,
            "{what}"
        );
        assert_eq!(ds["machine_id"], machine.as_str(), "{what}");
        let stored = app.client.datasets(&machine, false).await.unwrap();
        assert_eq!(stored.len(), 1, "{what}");
    }
}
