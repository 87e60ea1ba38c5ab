//! 5. **Scale of a plant group** (MTCAL_LOAD_SCALE=1; PostgreSQL only): MTCAL_LOAD_MACHINES
//!    (100 000) × MTCAL_LOAD_RESULTS (20) identifications in the schema MTCAL_LOAD_PG_URL
//!    names (else a fresh schema on `MTCAL_TEST_PG`'s server; its URL is printed for
//!    reuse). Seeding: 50 template machines through the store, each result carrying one
//!    real identification document (a simulated seed-plan session identified here) and
//!    realistic scalars; every other machine copies a template's machine row, jobs and
//!    results in SQL (`INSERT … SELECT generate_series`), with ids of its own; then the
//!    fleet rows are computed (`refresh_all`, timed) and the tables' sizes printed.
//!    Measuring: MTCAL_LOAD_CLIENTS (50) clients, each waiting MTCAL_LOAD_THINK_MS (100)
//!    between requests, read in turn the fleet page (HTML, signed in), `GET
//!    /api/v1/fleet?limit=100`, a random machine's term trend and its summary trend:
//!    first for MTCAL_LOAD_SECONDS (20), then while the fleet rows are refreshed after a
//!    row-format change (every stored basis made one format older, then `refresh_all` in
//!    the background on connections of its own, as `mtcal serve` runs it at start) until
//!    the refresh ends (or for MTCAL_LOAD_REFRESH_SECONDS).

use super::{env, latencies, machine, seeded_scalars, sign_in, start};
use mtcal_client::Client;
use mtcal_server::api::fleet::FleetParams;
use mtcal_solver::identification::{IdentifyOptions, identify};
use mtcal_solver::simulate::{SimOptions, random_truth, simulate};
use mtcal_store::prelude::*;
use mtcal_store::{NewResult, PostgresStore, Scope};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::json;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Machines seeded through the store; machine `i` copies template `i % TEMPLATES` (a
/// multiple of 10: the copy keeps the last digit, so its site and tag are its own).
const TEMPLATES: usize = 50;

/// Machines copied by one SQL statement.
const CHUNK: usize = 2_000;

/// The four reads of a client, in turn.
const READS: [&str; 4] = [
    "fleet page (HTML)",
    "GET /api/v1/fleet?limit=100",
    "trends/term (a machine)",
    "trends/summary (a machine)",
];

pub async fn run() {
    let (m, r) = (
        env("MTCAL_LOAD_MACHINES", 100_000),
        env("MTCAL_LOAD_RESULTS", 20),
    );
    assert!(
        m.is_multiple_of(TEMPLATES) && m <= 100_000,
        "MTCAL_LOAD_MACHINES: a multiple of {TEMPLATES} up to 100 000"
    );
    let url = match std::env::var("MTCAL_LOAD_PG_URL") {
        Ok(url) => url,
        Err(_) => {
            let s = mtcal_store::testing::ScratchPg::create("scale")
                .await
                .unwrap()
                .expect("MTCAL_TEST_PG names a server");
            println!("schema {}: MTCAL_LOAD_PG_URL='{}'", s.schema, s.url);
            s.url
        }
    };
    let store: Arc<dyn Store> = Arc::new(PostgresStore::open(&url).await.unwrap());
    let pool = sqlx::PgPool::connect(&url).await.unwrap();
    let have = store.row_counts().await.unwrap().results;
    if have == 0 {
        seed(store.as_ref(), &pool, m, r).await;
    } else {
        assert_eq!(have, (m * r) as i64, "a schema seeded with another size");
    }
    sizes(&pool).await;
    if env("MTCAL_LOAD_SEED_ONLY", 0) > 0 {
        return;
    }
    measure(store, &url, &pool, m).await;
}

/// One real identification document: a simulated seed-plan session (10 Hz) identified.
fn real_document() -> serde_json::Value {
    let sim = simulate(
        &random_truth(7),
        &SimOptions {
            seed: 7,
            sample_rate_hz: 10.0,
            machine_id: "M00000".into(),
            ..SimOptions::default()
        },
    )
    .unwrap();
    let result = identify(&sim.session, &IdentifyOptions::default()).unwrap();
    serde_json::to_value(&result).unwrap()
}

async fn seed(store: &dyn Store, pool: &sqlx::PgPool, m: usize, r: usize) {
    let t = Instant::now();
    let document = real_document();
    let model = mtcal_domain::trends::check_model(&document);
    println!(
        "seeding {m} machines x {r} results; the document: {} bytes of JSON",
        document.to_string().len()
    );
    let all_real = std::env::var("MTCAL_LOAD_SCALE_DOCS").is_ok_and(|v| v == "all");
    let mut rng = StdRng::seed_from_u64(6);
    let mut batch = Vec::new();
    for i in 0..TEMPLATES {
        let id = format!("M{i:05}");
        store.create_machine(&machine(&id)).await.unwrap();
        batch.extend((0..r).map(|k| NewResult {
            machine_id: id.clone(),
            dataset_id: None,
            kind: "identification".into(),
            measured_at: format!("{}-{:02}-01T08:00:00Z", 2000 + k / 12, 1 + k % 12),
            // The latest check's document is what the fleet rows read; the others are
            // read only by a trend's misfit marks (every real: MTCAL_LOAD_SCALE_DOCS=all).
            document: if k + 1 == r || all_real {
                document.clone()
            } else {
                json!({"kind": "identification", "seeded": true})
            },
            check_model: Some(if k + 1 == r || all_real {
                model.clone()
            } else {
                Default::default()
            }),
            scalars: {
                let quarter = k + rng.random_range(0..8);
                seeded_scalars(&mut rng, quarter)
            },
            figures: vec![],
        }));
    }
    store.import_results_bulk(&batch).await.unwrap();
    // The templates' fleet rows, copied below with the rest.
    mtcal_domain::fleet::refresh_all(store).await.unwrap();
    estimate(pool, m * r).await;
    let id = |v: &str| format!("'M' || lpad(({v})::text, 5, '0')");
    // The copy's baseline and latest result ids (named by the template row's basis).
    let new_ids = |text: &str| {
        let ids = [2, 3].map(|k| format!("split_part(t.basis, ' ', {k})"));
        format!(
            "replace(replace({text}, {0}, 'res_' || md5({0} || i)), {1}, 'res_' || md5({1} || i))",
            ids[0], ids[1]
        )
    };
    let copies = [
        (
            "machines",
            vec![
                ("id", id("i")),
                ("name", id("i")),
                ("baseline_result_id", "NULL".into()),
            ],
            "machines t ON t.id = {T}",
        ),
        (
            "jobs",
            vec![
                ("id", "'job_' || md5(t.id || i)".into()),
                ("machine_id", id("i")),
                ("result_id", "'res_' || md5(tr.id || i)".into()),
            ],
            "results tr ON tr.machine_id = {T} JOIN jobs t ON t.id = tr.job_id",
        ),
        (
            "results",
            vec![
                ("id", "'res_' || md5(t.id || i)".into()),
                ("job_id", "'job_' || md5(t.job_id || i)".into()),
                ("machine_id", id("i")),
            ],
            "results t ON t.machine_id = {T}",
        ),
        (
            "fleet_drift",
            vec![
                ("machine_id", id("i")),
                (
                    "entry",
                    format!(
                        "replace({}, '\"' || t.machine_id || '\"', '\"' || {} || '\"')",
                        new_ids("t.entry"),
                        id("i")
                    ),
                ),
                ("basis", new_ids("t.basis")),
            ],
            "fleet_drift t ON t.machine_id = {T}",
        ),
    ];
    for lo in (TEMPLATES..m).step_by(CHUNK) {
        let hi = (lo + CHUNK).min(m) - 1;
        let mut tx = pool.begin().await.unwrap();
        for (table, set, from) in &copies {
            let sql = copy_sql(
                pool,
                table,
                set,
                &from.replace("{T}", &id("i % 50")),
                lo,
                hi,
            )
            .await;
            sqlx::query(sqlx::AssertSqlSafe(sql))
                .execute(&mut *tx)
                .await
                .unwrap();
        }
        tx.commit().await.unwrap();
        eprint!(
            "\r  copied {} machines ({:.0} s)",
            hi + 1,
            t.elapsed().as_secs_f64()
        );
    }
    eprintln!();
    sqlx::raw_sql("ANALYZE machines; ANALYZE jobs; ANALYZE results; ANALYZE fleet_drift")
        .execute(pool)
        .await
        .unwrap();
    println!("  seeded in {:.0} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let n = mtcal_domain::fleet::refresh_all(store).await.unwrap();
    println!(
        "  refresh at start: {} machines, {} rows recomputed (the copies' rows current), {:.1} s",
        n.machines,
        n.recomputed,
        t.elapsed().as_secs_f64()
    );
}

/// Storage before the copy, from the templates' rows as stored (each document compressed
/// by TOAST), for `n` results.
async fn estimate(pool: &sqlx::PgPool, n: usize) {
    // Storage before the copy: each row as stored (the document compressed by TOAST).
    let (raw, stored, row): (f64, f64, f64) = sqlx::query_as(
        "SELECT avg(octet_length(document))::float8, avg(pg_column_size(document))::float8, \
         avg(pg_column_size(r.*))::float8 FROM results r",
    )
    .fetch_one(pool)
    .await
    .unwrap();
    let n = n as f64;
    println!(
        "  a result (mean of the templates'): document {raw:.0} B, stored {stored:.0} B \
         ({:.1}x compressed), row {row:.0} B; estimate for {n} results: {:.2} GB before \
         indexes and jobs",
        raw / stored,
        row * n / 1e9
    );
}

/// `INSERT INTO table (every column) SELECT …` for machines `lo..=hi`: the columns of
/// `set` from their expressions, every other column copied from the template row `t`.
async fn copy_sql(
    pool: &sqlx::PgPool,
    table: &str,
    set: &[(&str, String)],
    from: &str,
    lo: usize,
    hi: usize,
) -> String {
    let columns: Vec<(String,)> = sqlx::query_as(
        "SELECT column_name::text FROM information_schema.columns \
         WHERE table_name = $1 AND table_schema = current_schema() ORDER BY ordinal_position",
    )
    .bind(table)
    .fetch_all(pool)
    .await
    .unwrap();
    let names: Vec<&str> = columns.iter().map(|(c,)| c.as_str()).collect();
    let values: Vec<String> = names
        .iter()
        .map(|c| match set.iter().find(|(s, _)| s == c) {
            Some((_, e)) => e.clone(),
            None => format!("t.{c}"),
        })
        .collect();
    format!(
        "INSERT INTO {table} ({}) SELECT {} FROM generate_series({lo}, {hi}) i JOIN {from}",
        names.join(", "),
        values.join(", ")
    )
}

/// The sizes of the tables the seed wrote (with their indexes and TOAST).
async fn sizes(pool: &sqlx::PgPool) {
    let rows: Vec<(String, i64, i64)> = sqlx::query_as(
        "SELECT c.relname::text, pg_total_relation_size(c.oid), pg_indexes_size(c.oid) \
         FROM pg_class c WHERE c.relnamespace = current_schema()::regnamespace \
         AND c.relkind = 'r' AND c.relname IN ('machines', 'jobs', 'results', 'fleet_drift') \
         ORDER BY 1",
    )
    .fetch_all(pool)
    .await
    .unwrap();
    for (name, total, indexes) in rows {
        println!(
            "  {name:12} {:.2} GB (indexes {:.2} GB)",
            total as f64 / 1e9,
            indexes as f64 / 1e9
        );
    }
}

/// Latencies of every read, by kind: `clients` clients until `stop` is set.
async fn reads(
    base: &str,
    key: &str,
    m: usize,
    clients: usize,
    think: u64,
    stop: Arc<AtomicBool>,
) -> BTreeMap<&'static str, Vec<f64>> {
    let (http, cookie) = sign_in(base, key).await;
    let failed = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let mut tasks = Vec::new();
    for c in 0..clients {
        let (base, key, http, stop) = (
            base.to_string(),
            key.to_string(),
            http.clone(),
            stop.clone(),
        );
        let cookie = format!("mtcal_session={cookie}");
        let failed = failed.clone();
        tasks.push(tokio::spawn(async move {
            let client = Client::new(&base, &key);
            let mut rng = StdRng::seed_from_u64(200 + c as u64);
            let mut lat: Vec<(usize, f64)> = Vec::new();
            let mut i = c;
            while !stop.load(Ordering::Relaxed) {
                let mid = format!("M{:05}", rng.random_range(0..m));
                let t = Instant::now();
                // A read that fails (a connection closed under it) is counted, not timed.
                let read: Result<(), String> = match i % READS.len() {
                    0 => match http
                        .get(format!("{base}/"))
                        .header(reqwest::header::COOKIE, &cookie)
                        .send()
                        .await
                    {
                        Ok(r) => {
                            assert!(r.status().is_success(), "fleet page: {}", r.status());
                            assert!(r.text().await.unwrap().contains("data-machine="));
                            Ok(())
                        }
                        Err(e) => Err(e.to_string()),
                    },
                    1 => {
                        let q = FleetParams {
                            limit: Some(100),
                            ..FleetParams::default()
                        };
                        client
                            .fleet(&q)
                            .await
                            .map(|p| assert_eq!(p.machines.len(), 100))
                            .map_err(|e| e.to_string())
                    }
                    2 => client
                        .term_trend(&mid, "EXX", &[-50.0, 50.0])
                        .await
                        .map(|_| ())
                        .map_err(|e| e.to_string()),
                    _ => client
                        .summary_trend(&mid)
                        .await
                        .map(|_| ())
                        .map_err(|e| e.to_string()),
                };
                if let Err(e) = read {
                    eprintln!("a read failed: {e}");
                    failed.fetch_add(1, Ordering::Relaxed);
                    i += 1;
                    tokio::time::sleep(Duration::from_millis(think)).await;
                    continue;
                }
                lat.push((i % READS.len(), t.elapsed().as_secs_f64() * 1e3));
                i += 1;
                tokio::time::sleep(Duration::from_millis(think)).await;
            }
            lat
        }));
    }
    let mut by = BTreeMap::new();
    for t in tasks {
        for (kind, ms) in t.await.unwrap() {
            by.entry(READS[kind]).or_insert_with(Vec::new).push(ms);
        }
    }
    println!("  reads failed: {}", failed.load(Ordering::Relaxed));
    by
}

fn report(label: &str, secs: f64, by: &mut BTreeMap<&'static str, Vec<f64>>) {
    let n: usize = by.values().map(Vec::len).sum();
    println!(
        "{label}: {n} reads in {secs:.0} s ({:.0}/s)",
        n as f64 / secs
    );
    let mut all: Vec<f64> = by.values().flatten().copied().collect();
    for (kind, v) in by.iter_mut() {
        latencies(&format!("{kind:28}"), v);
    }
    latencies(&format!("{:28}", "every read"), &mut all);
}

async fn measure(store: Arc<dyn Store>, url: &str, pool: &sqlx::PgPool, m: usize) {
    let (clients, think) = (
        env("MTCAL_LOAD_CLIENTS", 50),
        env("MTCAL_LOAD_THINK_MS", 100),
    );
    let secs = env("MTCAL_LOAD_SECONDS", 20) as u64;
    let (_, key) = store.create_key(Scope::Read, "scale").await.unwrap();
    let base = start(store.clone(), false).await;
    let stop = Arc::new(AtomicBool::new(false));
    let timer = {
        let stop = stop.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_secs(secs)).await;
            stop.store(true, Ordering::Relaxed);
        })
    };
    let t = Instant::now();
    let mut quiet = reads(&base, &key, m, clients, think as u64, stop).await;
    timer.await.unwrap();
    report(
        &format!("{clients} clients, {think} ms between reads, {m} machines"),
        t.elapsed().as_secs_f64(),
        &mut quiet,
    );
    // A row-format change: every stored basis names the format before this one.
    let older = format!("v{}", mtcal_domain::fleet::ROW_FORMAT - 1);
    sqlx::query("UPDATE fleet_drift SET basis = $1 || substr(basis, position(' ' in basis))")
        .bind(&older)
        .execute(pool)
        .await
        .unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    // On connections of its own, as `mtcal serve` runs it.
    let own = mtcal_server::serve::start_up_store(url, store.clone(), Default::default())
        .await
        .unwrap();
    let refresh = {
        let (store, stop) = (own, stop.clone());
        tokio::spawn(async move {
            let t = Instant::now();
            let n = mtcal_domain::fleet::refresh_all(store.as_ref())
                .await
                .unwrap();
            stop.store(true, Ordering::Relaxed);
            (n, t.elapsed().as_secs_f64())
        })
    };
    // MTCAL_LOAD_REFRESH_SECONDS (0: until the refresh ends): reads beside the refresh
    // for that long, then its duration extrapolated from the rows rewritten so far.
    let window = env("MTCAL_LOAD_REFRESH_SECONDS", 0) as u64;
    if window > 0 {
        let stop = stop.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_secs(window)).await;
            stop.store(true, Ordering::Relaxed);
        });
    }
    let t = Instant::now();
    let mut during = reads(&base, &key, m, clients, think as u64, stop).await;
    let secs = t.elapsed().as_secs_f64();
    if refresh.is_finished() {
        let (n, took) = refresh.await.unwrap();
        println!(
            "refresh after a row-format change: {} of {} rows recomputed in {took:.1} s, reads beside it",
            n.recomputed, n.machines
        );
    } else {
        refresh.abort();
        let (done,): (i64,) =
            sqlx::query_as("SELECT count(*) FROM fleet_drift WHERE basis LIKE $1")
                .bind(format!("v{} %", mtcal_domain::fleet::ROW_FORMAT))
                .fetch_one(pool)
                .await
                .unwrap();
        println!(
            "refresh after a row-format change: {done} of {m} rows rewritten in {secs:.0} s \
             (stopped there), {:.0} rows/s: about {:.0} s for the fleet, reads beside it",
            done as f64 / secs,
            m as f64 * secs / done.max(1) as f64
        );
    }
    report("reads during the refresh", secs, &mut during);
}
