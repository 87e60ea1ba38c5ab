//! Load benchmark of the service (figures in BENCHMARKS.md, "Service (crates/server)").
//!
//! 1. **Jobs**: K small simulated sessions, each uploaded (multipart), identified and
//!    polled (every 10 ms) through a real HTTP server with one worker, one after another;
//!    compared with the bare work the worker does per job (strict read of the uploaded
//!    bytes + `identify`), timed in this process. Overhead = service / bare − 1.
//! 2. **Trends**: M machines × R results seeded directly through the store (compact
//!    documents; the scalar columns and term coefficients trend queries read are
//!    realistic: 10 identifiable cubic terms), then Q random trend queries over HTTP
//!    (keep-alive), alternating `trends/term?term=EXX&at=-50,50` and `trends/summary`;
//!    latency percentiles; then the fleet ranking (`fleet/drift`), the fleet list
//!    (`GET /api/v1/fleet`: a page of 100, and filtered by tag and by site) and the
//!    dashboard's fleet page (HTML, signed in with a session cookie). The seeded database
//!    is kept and reused (MTCAL_LOAD_DB).
//!    With `MTCAL_TEST_PG` set, the same on PostgreSQL (a fresh schema, seeded each run).
//! 3. **Throughput**: N identify jobs of one small session queued at once, drained by
//!    1 worker on SQLite and by 1, 2 and 4 workers on PostgreSQL (`MTCAL_TEST_PG`):
//!    jobs per second from the first submission to the last success.
//!
//! 4. **Reads under load** (only this part, when MTCAL_LOAD_CLIENTS is set): that many
//!    concurrent clients for MTCAL_LOAD_SECONDS (20) reading the fleet page, trends and
//!    results of MTCAL_LOAD_MACHINES (1000) × MTCAL_LOAD_RESULTS (20) seeded results,
//!    first with no job, then with identify jobs running beside them all the time; each
//!    client waits MTCAL_LOAD_THINK_MS (0) between its requests. On SQLite, and with
//!    `MTCAL_TEST_PG` set on PostgreSQL too (a fresh schema; MTCAL_LOAD_SQLITE=0 skips
//!    SQLite).
//!
//! 5. **Scale of a plant group** (only this part, when MTCAL_LOAD_SCALE is 1): the module
//!    `scale` (100 000 machines × 20 results on PostgreSQL, seeded in SQL; reads while the
//!    fleet rows are refreshed after a row-format change).
//!
//! `scripts/with-postgres cargo run -p mtcal-server --example load` (dev profile:
//! dependencies optimised). Environment: MTCAL_LOAD_JOBS (20), MTCAL_LOAD_MACHINES
//! (10000), MTCAL_LOAD_RESULTS (100), MTCAL_LOAD_QUERIES (4000), MTCAL_LOAD_DB (a file in
//! the temp dir), MTCAL_LOAD_THROUGHPUT (jobs per throughput run, 100; 0 skips),
//! MTCAL_LOAD_SQLITE (1; 0 skips the SQLite part of 2.), MTCAL_LOAD_PG_URL (the
//! PostgreSQL part of 2. in the schema this URL opens, seeded only if it is not yet:
//! a seeded schema is reused across runs instead of seeding a fresh one each time),
//! MTCAL_LOAD_SEED_ONLY (0; 1 seeds the stores of 2. and refreshes their fleet rows,
//! then stops before any query: seeding can run apart from the timed runs).

use mtcal_client::Client;
use mtcal_server::api::fleet::FleetParams;
use mtcal_server::api::jobs::SubmitJob;
use mtcal_server::jobs::JobKind;
use mtcal_server::{UploadLimits, WorkerConfig};
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{SimOptions, random_truth, simulate};
use mtcal_store::prelude::*;
use mtcal_store::{JobState, Machine, NewResult, QueueConfig, ResultScalars, Scope, SqliteStore};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::json;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

#[path = "load/scale.rs"]
mod scale;

/// The `mtcal` binary's allocator (src/main.rs), so the service here allocates as it does.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn pct(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() as f64 - 1.0) * p).round() as usize]
}

async fn start(store: Arc<dyn Store>, worker: bool) -> String {
    start_with(store, worker, 1).await
}

async fn start_with(store: Arc<dyn Store>, worker: bool, concurrency: usize) -> String {
    let cfg = WorkerConfig {
        queue: QueueConfig {
            concurrency,
            poll_ms: 20,
            ..QueueConfig::default()
        },
        ..WorkerConfig::default()
    };
    let addr = mtcal_server::spawn_local(store, &cfg, worker)
        .await
        .unwrap();
    format!("http://{addr}")
}

/// Submits an identification of the dataset `dataset_id`.
async fn submit_identify(client: &Client, dataset_id: &str) -> mtcal_store::Job {
    client
        .submit(&SubmitJob {
            kind: JobKind::Identify,
            dataset_id: Some(dataset_id.to_string()),
            machine_id: None,
            params: json!({}),
        })
        .await
        .unwrap()
}

fn machine(id: &str) -> Machine {
    Machine {
        id: id.into(),
        name: id.into(),
        topology: json!({"workpiece": ["X", "Y"], "tool": ["Z"]}),
        travel_mm: BTreeMap::from([
            ("X".into(), [-100.0, 100.0]),
            ("Y".into(), [-100.0, 100.0]),
            ("Z".into(), [-100.0, 100.0]),
        ]),
        // Half the fleet tagged `vmc`, half `hmc` (the fleet page's tag filter).
        site: Some(
            if id.ends_with(['0', '1', '2']) {
                "north"
            } else {
                "south"
            }
            .into(),
        ),
        tags: vec![
            if id.ends_with(['0', '2', '4', '6', '8']) {
                "vmc"
            } else {
                "hmc"
            }
            .into(),
        ],
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    }
}

async fn jobs_bench(k: usize) {
    let dir = tempfile::tempdir().unwrap();
    let store = Arc::new(
        SqliteStore::open(dir.path().join("jobs.sqlite").to_str().unwrap())
            .await
            .unwrap(),
    );
    let (_, key) = store.create_key(Scope::Write, "load").await.unwrap();
    store.create_machine(&machine("LOAD-1")).await.unwrap();
    let client = Client::new(&start(store.clone(), true).await, &key);
    let (mut bare, mut svc, mut read, mut up, mut run) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut samples = 0;
    for i in 0..k {
        let sim = simulate(
            &random_truth(i as u64),
            &SimOptions {
                seed: i as u64,
                sample_rate_hz: 10.0,
                machine_id: "LOAD-1".into(),
                measured_at: format!("2026-01-01T00:{:02}:{:02}Z", i / 60, i % 60),
                ..SimOptions::default()
            },
        )
        .unwrap();
        let sdir = dir.path().join(format!("s{i}"));
        mtcal_formats::write_session_dir(&sdir, &sim.session).unwrap();
        let files = mtcal_client::files_to_upload(&sdir).unwrap();
        samples = sim.session.sample_count();

        // Bare: what the worker computes for the job.
        let t = Instant::now();
        let mtcal_formats::DatasetData::Session(session) =
            mtcal_formats::read_upload(&files, &UploadLimits::default())
                .unwrap()
                .data
        else {
            unreachable!("a session folder")
        };
        read.push(t.elapsed().as_secs_f64());
        let r = identify(&session, &IdentifyOptions::default()).unwrap();
        bare.push(t.elapsed().as_secs_f64());
        std::hint::black_box(r);

        // Service: upload, submit, poll until done, fetch the result.
        let t = Instant::now();
        let ds = client.upload_files("LOAD-1", &files).await.unwrap();
        up.push(t.elapsed().as_secs_f64());
        let job = submit_identify(&client, &ds.id).await;
        let j = client
            .wait_job(
                &job.id,
                Duration::from_secs(600),
                Duration::from_millis(10),
                |_| {},
            )
            .await
            .unwrap();
        assert_eq!(j.state, JobState::Succeeded, "{j:?}");
        let ts = |t: &Option<String>| {
            time::OffsetDateTime::parse(
                t.as_deref().unwrap(),
                &time::format_description::well_known::Rfc3339,
            )
            .unwrap()
        };
        run.push((ts(&j.finished_at) - ts(&j.started_at)).as_seconds_f64());
        client.job_result(&job.id).await.unwrap();
        svc.push(t.elapsed().as_secs_f64());
    }
    // Medians: the figures are robust to the other processes sharing the machine.
    let mean = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        pct(&v, 0.5)
    };
    let (b, s) = (mean(&bare), mean(&svc));
    println!("jobs: {k} sessions of {samples} samples (seed plan, 10 Hz), sequential, 1 worker");
    println!(
        "  bare read+identify  median {:.1} ms (of which strict read {:.1} ms)",
        b * 1e3,
        mean(&read) * 1e3
    );
    println!(
        "  service end to end  median {:.1} ms (upload + submit + poll + result)",
        s * 1e3
    );
    println!(
        "  of which upload {:.1} ms, job claimed→finished {:.1} ms (server clock)",
        mean(&up) * 1e3,
        mean(&run) * 1e3
    );
    println!("  overhead            {:+.1} %", (s / b - 1.0) * 100.0);
}

fn seeded_scalars(rng: &mut StdRng, quarter: usize) -> ResultScalars {
    let names = [
        "EXX", "EZX", "EBX", "EXY", "EYY", "EZY", "EAY", "ECY", "EZZ", "EYX",
    ];
    let mut coeffs = BTreeMap::new();
    for n in names {
        let c1 = if n.starts_with("EX") && n != "EXX" || n == "EZX" || n == "EZY" || n == "EYX" {
            0.0
        } else {
            0.02 * rng.random::<f64>()
        };
        coeffs.insert(
            n.to_string(),
            vec![
                c1 + 1e-4 * quarter as f64,
                1e-5 * rng.random::<f64>(),
                1e-7 * rng.random::<f64>(),
            ],
        );
    }
    ResultScalars {
        summary: mtcal_store::ResultSummary {
            residual_rms_um: Some(0.1 + 0.01 * rng.random::<f64>()),
            condition_number: Some(27.0),
            rank: Some(39),
            ec0y_urad: Some(10.0 + quarter as f64 * 0.3),
            eb0z_urad: None,
            ea0z_urad: None,
        },
        measured_travel_mm: ["X", "Y", "Z"]
            .map(|a| (a.to_string(), [-100.0, 100.0]))
            .into(),
        term_covariance: coeffs
            .keys()
            .map(|n| {
                let d = [1e-6, 1e-10, 1e-14];
                let cov = (0..3)
                    .map(|i| (0..3).map(|j| if i == j { d[i] } else { 0.0 }).collect())
                    .collect();
                (n.clone(), cov)
            })
            .collect(),
        term_coefficients: coeffs,
    }
}

/// A fresh store: a SQLite file in `dir`, or a new schema on the PostgreSQL server
/// `MTCAL_TEST_PG` names.
async fn fresh_store(pg: bool, dir: &std::path::Path, name: &str) -> Arc<dyn Store> {
    if pg {
        let scratch = mtcal_store::testing::ScratchPg::create(name)
            .await
            .unwrap()
            .expect("MTCAL_TEST_PG names a server");
        Arc::new(
            mtcal_store::PostgresStore::open(&scratch.url)
                .await
                .unwrap(),
        )
    } else {
        let path = dir.join(format!("{name}.sqlite"));
        Arc::new(SqliteStore::open(path.to_str().unwrap()).await.unwrap())
    }
}

/// `n` identify jobs of one small session, queued at once and drained by `workers`
/// worker slots; jobs per second from the first submission to the last success.
/// The upload files of a simulated seed-plan session (10 Hz) of `machine` from truth and
/// noise `seed`, written under `dir`.
fn session_files(dir: &std::path::Path, machine: &str, seed: u64) -> mtcal_client::Files {
    let sim = simulate(
        &random_truth(seed),
        &SimOptions {
            seed,
            sample_rate_hz: 10.0,
            machine_id: machine.into(),
            ..SimOptions::default()
        },
    )
    .unwrap();
    let sdir = dir.join(format!("{machine}-{seed}"));
    mtcal_formats::write_session_dir(&sdir, &sim.session).unwrap();
    mtcal_client::files_to_upload(&sdir).unwrap()
}

/// `r` seeded identifications of machine `id` (compact documents, realistic scalars),
/// one a month from January 2000.
fn seeded_results(rng: &mut StdRng, id: &str, r: usize) -> Vec<NewResult> {
    (0..r)
        .map(|k| NewResult {
            machine_id: id.to_string(),
            dataset_id: None,
            kind: "identification".into(),
            measured_at: format!("{}-{:02}-01T08:00:00Z", 2000 + k / 12, 1 + k % 12),
            document: json!({"kind": "identification", "seeded": true}),
            check_model: Some(Default::default()),
            scalars: seeded_scalars(rng, k),
            figures: vec![],
        })
        .collect()
}

async fn throughput_bench(pg: bool, workers: usize, n: usize) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let store = fresh_store(pg, dir.path(), &format!("throughput_{workers}")).await;
    let (_, key) = store.create_key(Scope::Write, "load").await.unwrap();
    store.create_machine(&machine("LOAD-T")).await.unwrap();
    let files = session_files(dir.path(), "LOAD-T", 3);
    let client = Client::new(&start_with(store.clone(), true, workers).await, &key);
    let ds = client.upload_files("LOAD-T", &files).await.unwrap();
    let t = Instant::now();
    for _ in 0..n {
        submit_identify(&client, &ds.id).await;
    }
    loop {
        let counts = store.job_counts().await.unwrap();
        let done: i64 = counts
            .iter()
            .filter(|c| c.state == "succeeded")
            .map(|c| c.count)
            .sum();
        assert!(counts.iter().all(|c| c.state != "failed"), "{counts:?}");
        if done as usize == n {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    n as f64 / t.elapsed().as_secs_f64()
}

async fn trends_bench(m: usize, r: usize, q: usize, pg: bool) {
    let path = std::env::var("MTCAL_LOAD_DB").unwrap_or_else(|_| {
        std::env::temp_dir()
            .join(format!("mtcal-load-{m}x{r}.sqlite"))
            .display()
            .to_string()
    });
    let store: Arc<dyn Store> = if pg {
        match std::env::var("MTCAL_LOAD_PG_URL") {
            // A schema seeded by an earlier run (its URL sets `search_path`): reused.
            Ok(url) => Arc::new(mtcal_store::PostgresStore::open(&url).await.unwrap()),
            Err(_) => fresh_store(true, std::path::Path::new("."), "trends").await,
        }
    } else {
        Arc::new(SqliteStore::open(&path).await.unwrap())
    };
    let have = store.row_counts().await.unwrap();
    if have.results < (m * r) as i64 {
        let t = Instant::now();
        let mut rng = StdRng::seed_from_u64(1);
        for i in 0..m {
            let id = format!("M{i:05}");
            if store.get_machine(&id).await.is_err() {
                store.create_machine(&machine(&id)).await.unwrap();
            }
        }
        let mut batch = Vec::new();
        for i in 0..m {
            batch.extend(seeded_results(&mut rng, &format!("M{i:05}"), r));
            if batch.len() >= 20_000 || i + 1 == m {
                store.import_results_bulk(&batch).await.unwrap();
                batch.clear();
                eprint!("\rseeded {} machines", i + 1);
            }
        }
        eprintln!(" in {:.0} s", t.elapsed().as_secs_f64());
    }
    let t = Instant::now();
    let n = mtcal_domain::fleet::refresh_all(store.as_ref())
        .await
        .unwrap();
    println!(
        "fleet rows of {} machines refreshed ({} recomputed) in {:.1} s (what `mtcal serve` does at start)",
        n.machines,
        n.recomputed,
        t.elapsed().as_secs_f64()
    );
    if env("MTCAL_LOAD_SEED_ONLY", 0) > 0 {
        return;
    }
    let (_, key) = store.create_key(Scope::Read, "load").await.unwrap();
    let base = start(store.clone(), false).await;
    let client = Client::new(&base, &key);
    let mut rng = StdRng::seed_from_u64(2);
    let (mut term, mut summary) = (Vec::new(), Vec::new());
    for i in 0..q + 200 {
        let mid = format!("M{:05}", rng.random_range(0..m));
        let t = Instant::now();
        let points = if i % 2 == 0 {
            let v = client
                .term_trend(&mid, "EXX", &[-50.0, 50.0])
                .await
                .unwrap();
            v.points.len()
        } else {
            client.summary_trend(&mid).await.unwrap().points.len()
        };
        let dt = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(points, r);
        if i >= 200 {
            if i % 2 == 0 {
                term.push(dt)
            } else {
                summary.push(dt)
            }
        }
    }
    println!(
        "trends on {}: {m} machines x {r} results, {q} queries after 200 warm-up, one client, keep-alive",
        if pg { "PostgreSQL" } else { "SQLite" }
    );
    for (name, v) in [("term EXX at -50,50", &mut term), ("summary", &mut summary)] {
        v.sort_by(f64::total_cmp);
        println!(
            "  {name:20} p50 {:.2} ms  p95 {:.2} ms  p99 {:.2} ms  max {:.2} ms",
            pct(v, 0.5),
            pct(v, 0.95),
            pct(v, 0.99),
            v[v.len() - 1]
        );
    }
    let mut fleet = Vec::new();
    for i in 0..220 {
        let t = Instant::now();
        let by = if i % 2 == 0 { "um" } else { "urad" };
        client.fleet_drift(Some(by), Some(50)).await.unwrap();
        if i >= 20 {
            fleet.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    latencies(
        &format!("fleet drift (top 50 of {m}, by um/urad)"),
        &mut fleet,
    );
    fleet_list_bench(&client, m).await;
    fleet_page_bench(&base, &key, m).await;
}

/// One latency line: `label  p50 … p90 … p95 … p99 … max …` (milliseconds, sorted here).
fn latencies(label: &str, v: &mut [f64]) {
    v.sort_by(f64::total_cmp);
    println!(
        "  {label}  p50 {:.2} ms  p90 {:.2} ms  p95 {:.2} ms  p99 {:.2} ms  max {:.2} ms",
        pct(v, 0.5),
        pct(v, 0.9),
        pct(v, 0.95),
        pct(v, 0.99),
        v[v.len() - 1]
    );
}

/// `GET /api/v1/fleet` (JSON, the fleet page's function): 3 × 220 requests, the first
/// 20 of each view discarded, round robin over a page of 100 in the default order
/// (drift, alerts first), the same filtered by tag (`tag=vmc`, half the fleet) and by
/// site (`site=north`, 3 in 10).
async fn fleet_list_bench(client: &Client, m: usize) {
    let views = [
        ("", None, None),
        (", tag=vmc", Some("vmc"), None),
        (", site=north", None, Some("north")),
    ];
    // Each view's machines in all, from the seeded machines' sites and tags.
    let totals = views.map(|(_, tag, site)| {
        (0..m)
            .map(|i| machine(&format!("M{i:05}")))
            .filter(|x| tag.is_none_or(|t: &str| x.tags.iter().any(|g| g == t)))
            .filter(|x| site.is_none_or(|s| x.site.as_deref() == Some(s)))
            .count()
    });
    let mut times = vec![Vec::new(); views.len()];
    for i in 0..220 * views.len() {
        let ((_, tag, site), total) = (views[i % views.len()], totals[i % views.len()]);
        let q = FleetParams {
            tag: tag.map(Into::into),
            site: site.map(Into::into),
            limit: Some(100),
            ..FleetParams::default()
        };
        let t = Instant::now();
        let page = client.fleet(&q).await.unwrap();
        let dt = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!((page.total, page.machines.len()), (total, total.min(100)));
        if i >= 20 * views.len() {
            times[i % views.len()].push(dt);
        }
    }
    for ((filter, ..), v) in views.iter().zip(&mut times) {
        latencies(&format!("fleet list (JSON, 100 of {m}{filter})"), v);
    }
}

/// The value of cookie `name` in a response's `Set-Cookie` headers.
fn set_cookie(r: &reqwest::Response, name: &str) -> Option<String> {
    r.headers()
        .get_all(reqwest::header::SET_COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .find_map(|v| {
            let pair = v.split(';').next()?;
            let (n, value) = pair.split_once('=')?;
            (n.trim() == name).then(|| value.to_string())
        })
}

/// A browser session of the dashboard signed in with API key `key`: the HTTP client (no
/// redirects followed) and the `mtcal_session` cookie's value.
async fn sign_in(base: &str, key: &str) -> (reqwest::Client, String) {
    let http = reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .build()
        .unwrap();
    let form = http.get(format!("{base}/signin")).send().await.unwrap();
    let pre = set_cookie(&form, "mtcal_signin").expect("sign-in cookie");
    let html = form.text().await.unwrap();
    let csrf = html
        .split(r#"name="csrf" value=""#)
        .nth(1)
        .and_then(|t| t.split('"').next())
        .expect("csrf field")
        .to_string();
    let signed = http
        .post(format!("{base}/signin"))
        .header(reqwest::header::COOKIE, format!("mtcal_signin={pre}"))
        .form(&[("csrf", csrf.as_str()), ("key", key), ("next", "/")])
        .send()
        .await
        .unwrap();
    let session = set_cookie(&signed, "mtcal_session").expect("session cookie");
    (http, session)
}

/// The dashboard's fleet page (HTML, one signed-in browser session): 220 requests after
/// signing in, the first 20 discarded, alternating the default order (drift, alerts
/// first), the µrad order, a tag filter and the second page (only when the fleet has
/// more machines than one page holds: a page past the last shows no machine).
async fn fleet_page_bench(base: &str, key: &str, m: usize) {
    let (http, session) = sign_in(base, key).await;
    let mut pages = vec!["/", "/?sort=drift_urad", "/?tag=vmc"];
    if m > mtcal_server::web::pages::FLEET_PAGE_ROWS {
        pages.push("/?page=2");
    }
    let (mut times, mut phases) = (Vec::new(), BTreeMap::<String, Vec<f64>>::new());
    for i in 0..220 {
        let t = Instant::now();
        let r = http
            .get(format!("{base}{}", pages[i % pages.len()]))
            .header(reqwest::header::COOKIE, format!("mtcal_session={session}"))
            .send()
            .await
            .unwrap();
        assert!(r.status().is_success(), "fleet page: {}", r.status());
        let timing = r
            .headers()
            .get("server-timing")
            .and_then(|v| v.to_str().ok())
            .unwrap_or_default()
            .to_string();
        let body = r.text().await.unwrap();
        assert!(body.contains("data-machine="), "a fleet page");
        if i >= 20 {
            times.push(t.elapsed().as_secs_f64() * 1e3);
            // `name;dur=ms, …`: the handler's phases.
            for part in timing.split(", ") {
                if let Some((name, ms)) = part.split_once(";dur=")
                    && let Ok(ms) = ms.parse::<f64>()
                {
                    phases.entry(name.to_string()).or_default().push(ms);
                }
            }
        }
    }
    latencies(
        &format!(
            "fleet page (HTML, {} of {m} machines, {} views)",
            m.min(mtcal_server::web::pages::FLEET_PAGE_ROWS),
            pages.len()
        ),
        &mut times,
    );
    for (name, v) in &mut phases {
        v.sort_by(f64::total_cmp);
        println!(
            "    of which {name:7} p50 {:.2} ms  p99 {:.2} ms  max {:.2} ms (Server-Timing)",
            pct(v, 0.5),
            pct(v, 0.99),
            v[v.len() - 1]
        );
    }
}

/// Reads under load: `clients` concurrent clients (each its own connection pool) for
/// `secs` seconds, each request one of: a fleet page of 100 (`GET /api/v1/fleet`), a
/// term trend, a summary trend, a stored result; on a fleet of `m` machines × `r`
/// results seeded through the store. With `busy`, identify jobs run beside them all the
/// time (2 workers, always 2 queued). Latency percentiles over every request.
async fn reads_under_load_bench(
    m: usize,
    r: usize,
    clients: usize,
    secs: u64,
    think: u64,
    busy: bool,
    pg: bool,
) {
    let dir = tempfile::tempdir().unwrap();
    let store = fresh_store(pg, dir.path(), "reads").await;
    let mut rng = StdRng::seed_from_u64(4);
    let mut batch = Vec::new();
    for i in 0..m {
        let id = format!("M{i:05}");
        store.create_machine(&machine(&id)).await.unwrap();
        batch.extend(seeded_results(&mut rng, &id, r));
    }
    store.import_results_bulk(&batch).await.unwrap();
    mtcal_domain::fleet::refresh_all(store.as_ref())
        .await
        .unwrap();
    let result_ids: Vec<String> = store
        .list_results("M00000", "identification")
        .await
        .unwrap()
        .into_iter()
        .map(|m| m.id)
        .collect();
    let (_, key) = store.create_key(Scope::Write, "load").await.unwrap();
    store.create_machine(&machine("LOAD-B")).await.unwrap();
    let base = start_with(store.clone(), true, 2).await;
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let jobs_done = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let feeder = if busy {
        let files = session_files(dir.path(), "LOAD-B", 5);
        let client = Client::new(&base, &key);
        let ds = client.upload_files("LOAD-B", &files).await.unwrap();
        let (stop, done, store) = (stop.clone(), jobs_done.clone(), store.clone());
        // The seeded results' own jobs are not counted.
        let before: i64 = store
            .job_counts()
            .await
            .unwrap()
            .iter()
            .filter(|c| c.state == "succeeded")
            .map(|c| c.count)
            .sum();
        Some(tokio::spawn(async move {
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let counts = store.job_counts().await.unwrap();
                let n = |st: &str| -> i64 {
                    counts
                        .iter()
                        .filter(|c| c.state == st)
                        .map(|c| c.count)
                        .sum()
                };
                done.store(
                    (n("succeeded") - before).max(0) as usize,
                    std::sync::atomic::Ordering::Relaxed,
                );
                if n("queued") < 2 {
                    submit_identify(&client, &ds.id).await;
                } else {
                    tokio::time::sleep(Duration::from_millis(20)).await;
                }
            }
        }))
    } else {
        None
    };
    let end = Instant::now() + Duration::from_secs(secs);
    let mut tasks = Vec::new();
    for c in 0..clients {
        let (base, key, ids) = (base.clone(), key.clone(), result_ids.clone());
        tasks.push(tokio::spawn(async move {
            let client = Client::new(&base, &key);
            let mut rng = StdRng::seed_from_u64(100 + c as u64);
            let mut lat = Vec::new();
            let mut i = c;
            while Instant::now() < end {
                let mid = format!("M{:05}", rng.random_range(0..m));
                let t = Instant::now();
                match i % 4 {
                    0 => {
                        client.fleet(&FleetParams::default()).await.unwrap();
                    }
                    1 => {
                        client
                            .term_trend(&mid, "EXX", &[-50.0, 50.0])
                            .await
                            .unwrap();
                    }
                    2 => {
                        client.summary_trend(&mid).await.unwrap();
                    }
                    _ => {
                        client
                            .result(&ids[rng.random_range(0..ids.len())])
                            .await
                            .unwrap();
                    }
                }
                lat.push(t.elapsed().as_secs_f64() * 1e3);
                i += 1;
                if think > 0 {
                    tokio::time::sleep(Duration::from_millis(think)).await;
                }
            }
            lat
        }));
    }
    let mut all = Vec::new();
    for t in tasks {
        all.extend(t.await.unwrap());
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    if let Some(f) = feeder {
        f.await.unwrap();
    }
    let n = all.len();
    println!(
        "reads under load ({}): {clients} clients (each waiting {think} ms between requests) for {secs} s on {m} machines x {r} results (fleet page, term trend, summary trend, result){}",
        if pg { "PostgreSQL" } else { "SQLite" },
        if busy {
            format!(
                ", identify jobs running beside (2 workers; {} finished)",
                jobs_done.load(std::sync::atomic::Ordering::Relaxed)
            )
        } else {
            ", no jobs".into()
        }
    );
    latencies(
        &format!("{n} requests, {:.0}/s", n as f64 / secs as f64),
        &mut all,
    );
}

#[tokio::main]
async fn main() {
    if env("MTCAL_LOAD_SCALE", 0) > 0 {
        scale::run().await;
        return;
    }
    let clients = env("MTCAL_LOAD_CLIENTS", 0);
    if clients > 0 {
        let secs = env("MTCAL_LOAD_SECONDS", 20) as u64;
        let (m, r) = (
            env("MTCAL_LOAD_MACHINES", 1000),
            env("MTCAL_LOAD_RESULTS", 20),
        );
        let think = env("MTCAL_LOAD_THINK_MS", 0) as u64;
        let pg = std::env::var_os(mtcal_store::testing::TEST_PG_VAR).is_some();
        let backends: &[bool] = match (env("MTCAL_LOAD_SQLITE", 1) > 0, pg) {
            (true, true) => &[false, true],
            (true, false) => &[false],
            (false, true) => &[true],
            (false, false) => &[],
        };
        for &pg in backends {
            reads_under_load_bench(m, r, clients, secs, think, false, pg).await;
            reads_under_load_bench(m, r, clients, secs, think, true, pg).await;
        }
        return;
    }
    let k = env("MTCAL_LOAD_JOBS", 20);
    if k > 0 {
        jobs_bench(k).await;
    }
    let pg = std::env::var_os(mtcal_store::testing::TEST_PG_VAR).is_some();
    let n = env("MTCAL_LOAD_THROUGHPUT", 100);
    if n > 0 {
        println!("throughput: {n} identify jobs of one seed-plan session (10 Hz), queued at once");
        let sqlite = throughput_bench(false, 1, n).await;
        println!("  SQLite, 1 worker:     {sqlite:.1} jobs/s");
        if pg {
            for w in [1, 2, 4] {
                let rate = throughput_bench(true, w, n).await;
                println!("  PostgreSQL, {w} worker(s): {rate:.1} jobs/s");
            }
        }
    }
    let m = env("MTCAL_LOAD_MACHINES", 10_000);
    if m > 0 {
        let (r, q) = (
            env("MTCAL_LOAD_RESULTS", 100),
            env("MTCAL_LOAD_QUERIES", 4000),
        );
        if env("MTCAL_LOAD_SQLITE", 1) > 0 {
            trends_bench(m, r, q, false).await;
        }
        if pg {
            trends_bench(m, r, q, true).await;
        }
    }
}
