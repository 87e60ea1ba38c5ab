//! Nothing stored that cannot be read back: seeded uploads, valid but extreme (every
//! number of `session.json` and CSV cells at, just inside and just beyond the bounds of
//! `docs/datasets.md`; few and many samples; positioning runs over the whole travel),
//! cradle (5-axis A/C) point sets with their sidecar, angles and ball positions at and
//! near their bounds; drift logs with times, speeds and displacements at and near theirs)
//! are sent through the API: 14 session and positioning cases and 6 of each of cradle and
//! drift log with every value within the bounds, which must be accepted, and one case per
//! field with that field beyond its bound, which must be refused (4xx) and store nothing.
//! Each accepted upload is run through every job kind that applies to it (identify,
//! diagnose, standards; cradle for a point set; one sensitivity per backend) by a
//! worker of this process, and then every GET route of the API (from the OpenAPI
//! document) and every page of the dashboard is read with its machine, dataset, results
//! and jobs, each export format too: no answer may be a 5xx, and no job may fail other
//! than on its input. Every failure is collected with its case's seed, route, status
//! and body. Runs on SQLite and, when `MTCAL_TEST_PG` names a server, on PostgreSQL.

use crate::common::routes::{
    Auth, Ids, api_routes, call, fill, missing, page_routes, send_as, session_of,
};
use crate::common::{Keys, app_with, request};
use axum::http::StatusCode;
use mtcal_server::WorkerConfig;
use mtcal_solver::diagnosis::series::simulate::{PositioningSim, simulate_positioning};
use mtcal_solver::simulate::{SimOptions, random_truth, simulate};
use mtcal_store::QueueConfig;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Cases within the bounds per backend; their seeds are `FIRST_SEED..FIRST_SEED + CASES`.
const CASES: u64 = 14;
const FIRST_SEED: u64 = 4100;
/// Then one case beyond the bounds per field ([`SESSION_FIELDS`], [`POSITIONING_FIELDS`],
/// [`CRADLE_FIELDS`], [`DRIFT_FIELDS`]), of seeds from `OVER_SEED` on.
const OVER_SEED: u64 = 4200;
const POSITIONING_FIELDS: [&str; 2] = ["range_mm", "deviation_um_cell"];
/// Cradle and drift-log cases within the bounds per backend, of seeds from `CRADLE_SEED`
/// and `DRIFT_SEED` on.
const MORE_CASES: u64 = 6;
const CRADLE_SEED: u64 = 4300;
const DRIFT_SEED: u64 = 4400;
const CRADLE_FIELDS: [&str; 2] = ["angle_cell", "position_cell"];
const DRIFT_FIELDS: [&str; 2] = ["time_cell", "value_cell"];

/// What an upload is: which generator makes it, and the job kinds run on it.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Session,
    Positioning,
    Cradle,
    Drift,
}

impl Kind {
    fn jobs(self) -> &'static [&'static str] {
        match self {
            Kind::Session => &["identify", "diagnose", "standards"],
            Kind::Positioning => &["diagnose", "standards"],
            Kind::Cradle => &["cradle"],
            Kind::Drift => &["diagnose"],
        }
    }

    /// The fields a case of this kind may push beyond their bounds.
    fn fields(self) -> &'static [&'static str] {
        match self {
            Kind::Session => &SESSION_FIELDS,
            Kind::Positioning => &POSITIONING_FIELDS,
            Kind::Cradle => &CRADLE_FIELDS,
            Kind::Drift => &DRIFT_FIELDS,
        }
    }
}
/// Upload limit of the app under test (the simulated sessions are a few hundred KB).
const MAX_UPLOAD: usize = 64 << 20;
const EXPORT_FORMATS: [&str; 5] = ["csv", "isg", "linuxcnc", "etalon", "heidenhain"];

type Files = Vec<(String, Vec<u8>)>;

/// One generated upload: what was changed (for the failure message) and its files.
struct Upload {
    what: Vec<String>,
    files: Files,
    kind: Kind,
    /// The field drawn beyond its bounds: the upload must be refused (else accepted).
    over: Option<&'static str>,
}

/// Draws a case's values: each field from its values within the bounds, except the one
/// field (if any) the case pushes beyond them; notes each draw as `name=…`.
struct Picker {
    rng: StdRng,
    what: Vec<String>,
    /// The field drawn beyond its bounds.
    over: Option<&'static str>,
}

impl Picker {
    /// A case of seed `seed` that pushes `over` (if any) beyond its bounds.
    fn new(seed: u64, over: Option<&'static str>) -> Picker {
        Picker {
            rng: StdRng::seed_from_u64(seed),
            what: vec![],
            over,
        }
    }

    fn pick<T: Clone + std::fmt::Debug>(
        &mut self,
        name: &'static str,
        within: &[T],
        beyond: &[T],
    ) -> T {
        let options = if self.over == Some(name) && !beyond.is_empty() {
            beyond
        } else {
            within
        };
        let v = options[self.rng.random_range(0..options.len())].clone();
        self.what.push(format!("{name}={v:?}"));
        v
    }
}

/// The fields of `session.json` and the plane files a session case draws.
const SESSION_FIELDS: [&str; 7] = [
    "temperature_c",
    "head_offset_mm",
    "temperature_u_k",
    "machine_expansion_ppm_per_k",
    "alignment_urad",
    "instrument_numbers",
    "du_um_cell",
];

/// A simulated seed-plan session of `machine` with its numbers drawn at and near the
/// bounds (`docs/datasets.md`: positions ±100 000 mm, temperatures ±1000 °C, expansion
/// ±100 ppm/K, deviations ±10 000 µm, any other value ≤ 10⁹).
fn session_upload(seed: u64, machine: &str, over: Option<&'static str>) -> Upload {
    let mut p = Picker::new(seed, over);
    let rate = p.pick("rate_hz", &[2.0, 10.0, 40.0], &[]);
    let sim = simulate(
        &random_truth(seed),
        &SimOptions {
            seed,
            sample_rate_hz: rate,
            machine_id: machine.into(),
            ..SimOptions::default()
        },
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    mtcal_formats::write_session_dir(dir.path(), &sim.session).unwrap();
    let mut files = mtcal_client::files_to_upload(dir.path()).unwrap();
    let json_at = files.iter().position(|(n, _)| n == "session.json").unwrap();
    let mut doc: Value = serde_json::from_slice(&files[json_at].1).unwrap();
    let (big, over) = (1e9, 1.000_001e9);
    let t = p.pick(
        "temperature_c",
        &[None, Some(20.0), Some(999.999), Some(1000.0), Some(-1000.0)],
        &[Some(1000.001), Some(5000.0)],
    );
    if let Some(t) = t {
        doc["temperature_c"] = json!(t);
    }
    let offset = p.pick(
        "head_offset_mm",
        &[
            [0.0, 0.0, -100.0],
            [100_000.0, 0.0, 0.0],
            [-100_000.0, 100_000.0, -100_000.0],
            [99_999.999, -5e-324, 0.0],
        ],
        &[[100_000.001, 0.0, 0.0], [1e20, 0.0, 0.0], [1e308, 0.0, 0.0]],
    );
    let planes = doc["planes"].as_array().unwrap().len();
    let plane = p.rng.random_range(0..planes);
    doc["planes"][plane]["head_offset_mm"] = json!(offset);
    let u = p.pick(
        "temperature_u_k",
        &[None, Some(0.0), Some(1000.0)],
        &[Some(1000.001)],
    );
    if let Some(u) = u {
        doc["temperature_u_k"] = json!(u);
    }
    let e = p.pick(
        "machine_expansion_ppm_per_k",
        &[None, Some(100.0_f64), Some(-100.0)],
        &[Some(100.001)],
    );
    if let Some(e) = e {
        doc["machine_expansion_ppm_per_k"] = json!(e);
        doc["machine_expansion_u_ppm_per_k"] = json!(e.abs());
    }
    let a = p.pick(
        "alignment_urad",
        &[None, Some(0.0), Some(big)],
        &[Some(over)],
    );
    if let Some(a) = a {
        doc["alignment_urad"] = json!(a);
    }
    let i = p.pick(
        "instrument_numbers",
        &[None, Some(0.0_f64), Some(big)],
        &[Some(over)],
    );
    if let Some(i) = i {
        doc["instrument"] = json!({
            "model": "KGM 282", "calibration_u_um": i, "calibration_u_um_per_m": i,
            "calibration_k": 2, "squareness_u_urad": i,
            "expansion_ppm_per_k": i.min(100.0), "expansion_u_ppm_per_k": i.min(100.0),
        });
    }
    files[json_at].1 = serde_json::to_vec_pretty(&doc).unwrap();
    let cell = p.pick(
        "du_um_cell",
        &[None, Some("10000"), Some("-10000"), Some("9999.999999")],
        &[Some("10000.000001"), Some("1e308")],
    );
    if let Some(cell) = cell {
        let csv = files.iter().position(|(n, _)| n.ends_with(".csv")).unwrap();
        files[csv].1 = set_cell(&files[csv].1, "du_um", &mut p.rng, cell);
    }
    Upload {
        what: p.what,
        files,
        kind: Kind::Session,
        over: p.over,
    }
}

/// `csv` with the cell of `column` on a random data line set to `value`.
fn set_cell(csv: &[u8], column: &str, rng: &mut StdRng, value: &str) -> Vec<u8> {
    let lines = String::from_utf8_lossy(csv).lines().count();
    let line = rng.random_range(1..lines);
    set_cell_at(csv, column, line, value)
}

/// `csv` with the cell of `column` on line `line` (0 the header) set to `value`.
fn set_cell_at(csv: &[u8], column: &str, line: usize, value: &str) -> Vec<u8> {
    let text = String::from_utf8(csv.to_vec()).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let col = lines[0].split(',').position(|c| c == column).unwrap();
    let mut cells: Vec<String> = lines[line].split(',').map(str::to_string).collect();
    cells[col] = value.into();
    lines[line] = cells.join(",");
    (lines.join("\n") + "\n").into_bytes()
}

/// Simulated positioning runs over ranges up to the whole travel the service accepts,
/// with errors up to the deviation bound, few and many targets.
fn positioning_upload(seed: u64, over: Option<&'static str>) -> Upload {
    let mut p = Picker::new(seed, over);
    let (lo, hi) = p.pick(
        "range_mm",
        &[
            (0.0, 500.0),
            (-100_000.0, 100_000.0),
            (99_990.0, 100_000.0),
            (0.0, 0.01),
        ],
        &[(0.0, 100_000.01)],
    );
    let targets = p.pick("targets", &[2usize, 5, 21, 400], &[]);
    let runs = p.pick("runs", &[1usize, 2, 5], &[]);
    let smooth = p.pick("smooth_um", &[0.0, 15.0, 9_000.0], &[]);
    let noise = p.pick("noise_um", &[0.0, 0.5, 500.0], &[]);
    let sim = simulate_positioning(&PositioningSim {
        lo_mm: lo,
        hi_mm: hi,
        n_targets: targets,
        n_runs: runs,
        smooth_um: smooth,
        noise_um: noise,
        seed,
        ..PositioningSim::default()
    });
    let mut csv = vec![];
    mtcal_formats::write_positioning(&mut csv, &sim).unwrap();
    let cell = p.pick(
        "deviation_um_cell",
        &[None, Some("10000"), Some("-10000")],
        &[Some("10000.001")],
    );
    if let Some(cell) = cell {
        csv = set_cell(&csv, "deviation_um", &mut p.rng, cell);
    }
    Upload {
        what: p.what,
        files: vec![("positioning.csv".into(), csv)],
        kind: Kind::Positioning,
        over: p.over,
    }
}

/// A simulated cradle check (A carrying C, `docs/datasets.md` §2) of `machine` with its
/// sidecar: poses few and many, C turned near the angle bound (±36 000°), the ball near
/// the position bound (±100 000 mm), tracker noise up to 0.5 mm, a cell at or beyond.
fn cradle_upload(seed: u64, machine: &str, over: Option<&'static str>) -> Upload {
    use mtcal_solver::cradle::simulate::{CradleSimulation, Deflection, simulate_cradle};
    let mut p = Picker::new(seed, over);
    let deflection = p.pick(
        "deflection",
        &[Deflection::Rigid, Deflection::Pivot, Deflection::Mount],
        &[],
    );
    let mut sim = CradleSimulation::example_with(deflection, seed);
    let a_step = p.pick("a_step_deg", &[15.0, 30.0, 45.0], &[]);
    let steps = (90.0 / a_step) as i32;
    sim.a_deg = (-steps..=steps).map(|k| a_step * f64::from(k)).collect();
    let turns = p.pick("c_turns", &[0.0, 99.0, -99.0], &[]);
    sim.c_deg = (0..18)
        .map(|k| 360.0 * turns + 20.0 * f64::from(k) * if turns < 0.0 { -1.0 } else { 1.0 })
        .collect();
    let pivot = p.pick(
        "pivot_mm",
        &[
            [0.0, 0.0, 0.0],
            [99_700.0, -99_700.0, 0.0],
            [0.0, 0.0, -99_700.0],
        ],
        &[],
    );
    sim.truth.pivot_mm = pivot;
    sim.noise_um = p.pick("noise_um", &[0.0, 2.0, 500.0], &[]);
    let mut set = simulate_cradle(&sim);
    set.machine_id = Some(machine.into());
    set.measured_at = Some("2026-11-02T08:30:00Z".into());
    set.nominal_radius_mm = p.pick("nominal_radius_mm", &[None, Some(150.0), Some(1e9)], &[]);
    let mut csv = vec![];
    mtcal_formats::write_rotary_points(&mut csv, &set).unwrap();
    let angle = p.pick(
        "angle_cell",
        &[None, Some("36000"), Some("-36000")],
        &[Some("36000.001"), Some("1e9")],
    );
    if let Some(cell) = angle {
        csv = set_cell(&csv, "c_deg", &mut p.rng, cell);
    }
    let position = p.pick(
        "position_cell",
        &[None, Some("100000"), Some("-100000")],
        &[Some("100000.001")],
    );
    if let Some(cell) = position {
        csv = set_cell(&csv, "x_mm", &mut p.rng, cell);
    }
    let mut sidecar = vec![];
    mtcal_formats::write_rotary_sidecar(&mut sidecar, &set).unwrap();
    Upload {
        what: p.what,
        files: vec![("cradle.csv".into(), csv), ("cradle.json".into(), sidecar)],
        kind: Kind::Cradle,
        over: p.over,
    }
}

/// A simulated drift log (`docs/datasets.md` §4): short and long recordings up to the
/// time bound (10⁸ s), speeds and displacements up to the value bound (10⁹), a cell at
/// or beyond.
fn drift_upload(seed: u64, over: Option<&'static str>) -> Upload {
    use mtcal_solver::diagnosis::series::simulate::{DriftSim, simulate_drift_log};
    let mut p = Picker::new(seed, over);
    let (duration_s, dt_s) = p.pick(
        "span_s",
        &[(86_400.0, 30.0), (7_200.0, 1.0), (99_000_000.0, 100_000.0)],
        &[],
    );
    let rpm_max = p.pick("rpm_max", &[6000.0, 1e9], &[]);
    let gain_um = p.pick("gain_um", &[0.0, 20.0, 1e6], &[]);
    let noise_um = p.pick("noise_um", &[0.1, 5.0], &[]);
    let log = simulate_drift_log(&DriftSim {
        duration_s,
        dt_s,
        rpm_max,
        gain_um,
        tau_s: dt_s * 180.0,
        noise_um,
        seed,
    });
    let mut csv = vec![];
    mtcal_formats::write_drift_log(&mut csv, &log).unwrap();
    // The last time is the largest: at or beyond the bound there, still increasing.
    let time = p.pick(
        "time_cell",
        &[None, Some("100000000")],
        &[Some("100000000.5"), Some("1e12")],
    );
    if let Some(cell) = time {
        csv = set_cell_at(&csv, "t_s", log.t_s.len(), cell);
    }
    let value = p.pick(
        "value_cell",
        &[None, Some("1000000000"), Some("-1e9")],
        &[Some("1000000001"), Some("-1e10")],
    );
    if let Some(cell) = value {
        csv = set_cell(&csv, "ch1_um", &mut p.rng, cell);
    }
    Upload {
        what: p.what,
        files: vec![("drift.csv".into(), csv)],
        kind: Kind::Drift,
        over: p.over,
    }
}

/// A multipart body of `files` (boundary `mtcal-b`).
fn multipart(files: &Files) -> Vec<u8> {
    let mut body = vec![];
    for (name, bytes) in files {
        body.extend_from_slice(
            format!(
                "--mtcal-b\r\nContent-Disposition: form-data; name=\"file\"; filename=\"{name}\"\r\n\
                 Content-Type: application/octet-stream\r\n\r\n"
            )
            .as_bytes(),
        );
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    body.extend_from_slice(b"--mtcal-b--\r\n");
    body
}

/// The app, its keys, a dashboard session of the admin key, and what went wrong.
struct Run {
    app: axum::Router,
    keys: Keys,
    page: Auth,
    failures: Vec<String>,
    checks: usize,
    jobs: usize,
    /// Results made per kind of upload (each kind's jobs must make some).
    made: std::collections::BTreeMap<String, usize>,
}

impl Run {
    /// `GET uri` as `who`: a failure when the answer is a 5xx.
    async fn read(&mut self, case: &str, who: &Auth, uri: &str) {
        let (s, b) = send_as(&self.app, who, "GET", uri, None).await;
        self.checks += 1;
        if s.is_server_error() {
            self.failures.push(format!(
                "{case}: GET {uri}: {s} {:.300}",
                b.replace('\n', " ")
            ));
        }
    }

    async fn api(&self, method: &str, uri: &str, body: Option<&Value>) -> (StatusCode, Value) {
        let (s, b) = call(&self.app, method, uri, body, &self.keys.admin).await;
        (s, serde_json::from_str(&b).unwrap_or_default())
    }

    /// The number of datasets and of jobs of machine `m`.
    async fn counts(&self, m: &str) -> (usize, usize) {
        let (_, ds) = self
            .api("GET", &format!("/api/v1/machines/{m}/datasets"), None)
            .await;
        let (_, jobs) = self.api("GET", "/api/v1/jobs", None).await;
        let jobs = jobs
            .as_array()
            .map_or(0, |j| j.iter().filter(|j| j["machine_id"] == m).count());
        (ds.as_array().map_or(0, Vec::len), jobs)
    }

    /// Submits `job`, waits until it ends; its id and result id. A job that fails other
    /// than on its input (`bad_input`) is a failure.
    async fn job(&mut self, case: &str, job: Value) -> (String, Option<String>) {
        let (s, b) = self.api("POST", "/api/v1/jobs", Some(&job)).await;
        if s != StatusCode::ACCEPTED {
            self.failures
                .push(format!("{case}: submit {job}: {s} {b:.300}"));
            return (String::new(), None);
        }
        let id = b["id"].as_str().unwrap().to_string();
        self.jobs += 1;
        let start = Instant::now();
        loop {
            let (_, j) = self.api("GET", &format!("/api/v1/jobs/{id}"), None).await;
            match j["state"].as_str().unwrap_or_default() {
                "succeeded" => return (id, j["result_id"].as_str().map(str::to_string)),
                "failed" | "cancelled" => {
                    if j["error_code"] != "bad_input" {
                        self.failures.push(format!(
                            "{case}: job {} {id}: {} {} {}",
                            job["kind"], j["state"], j["error_code"], j["error_message"]
                        ));
                    }
                    return (id, None);
                }
                _ if start.elapsed() > Duration::from_secs(120) => {
                    self.failures
                        .push(format!("{case}: job {id} did not end: {j}"));
                    return (id, None);
                }
                _ => tokio::time::sleep(Duration::from_millis(20)).await,
            }
        }
    }
}

/// What one backend's run found: (cases, accepted, jobs, reads).
struct Tally {
    cases: usize,
    accepted: usize,
    jobs: usize,
    reads: usize,
}

async fn property(url: &str) -> Tally {
    let (app, keys, store) = app_with(url, MAX_UPLOAD).await;
    let page = session_of(&store, &keys.admin).await;
    let workers = mtcal_server::worker::spawn_workers(
        store.clone(),
        WorkerConfig {
            queue: QueueConfig {
                poll_ms: 10,
                backoff_base_ms: 10,
                backoff_max_ms: 50,
                ..QueueConfig::default()
            },
            ..WorkerConfig::default()
        },
        Arc::new(tokio::sync::Notify::new()),
    );
    let mut run = Run {
        app,
        keys,
        page,
        failures: vec![],
        checks: 0,
        jobs: 0,
        made: Default::default(),
    };
    let mut tally = Tally {
        cases: 0,
        accepted: 0,
        jobs: 0,
        reads: 0,
    };
    let within = (FIRST_SEED..FIRST_SEED + CASES).map(|seed| {
        let kind = if seed % 4 != 3 {
            Kind::Session
        } else {
            Kind::Positioning
        };
        (seed, kind, None)
    });
    let more = |first: u64, kind: Kind| (first..first + MORE_CASES).map(move |s| (s, kind, None));
    let within = within
        .chain(more(CRADLE_SEED, Kind::Cradle))
        .chain(more(DRIFT_SEED, Kind::Drift));
    let kinds = [Kind::Session, Kind::Positioning, Kind::Cradle, Kind::Drift];
    let fields = kinds
        .into_iter()
        .flat_map(|k| k.fields().iter().map(move |f| (k, Some(*f))));
    let over = (OVER_SEED..).zip(fields);
    let cases: Vec<_> = within
        .chain(over.map(|(seed, (k, f))| (seed, k, f)))
        .collect();
    tally.cases = cases.len();
    for (seed, kind, over) in cases {
        if one_case(&mut run, seed, kind, over, tally.accepted == 0).await {
            tally.accepted += 1;
        }
    }
    workers.shutdown().await;
    for kind in kinds {
        let made = run.made.get(&format!("{kind:?}")).copied().unwrap_or(0);
        if made == 0 {
            run.failures.push(format!("{kind:?}: no job made a result"));
        }
    }
    tally.reads = run.checks;
    tally.jobs = run.jobs;
    assert!(
        run.failures.is_empty(),
        "{} failures on {} (reproduce a case by its seed):\n{}",
        run.failures.len(),
        url.split(':').next().unwrap_or(url),
        run.failures.join("\n")
    );
    tally
}

/// One seeded case; true when its upload was accepted. The `first` accepted one also
/// gets a sensitivity job (it reads no upload: once is enough).
async fn one_case(
    run: &mut Run,
    seed: u64,
    kind: Kind,
    over: Option<&'static str>,
    first: bool,
) -> bool {
    let m = format!("PROP-{seed}");
    let body = json!({"id": m, "name": m, "site": "prop"});
    let (s, b) = run.api("POST", "/api/v1/machines", Some(&body)).await;
    assert_eq!(s, StatusCode::CREATED, "{b}");
    let profile = json!({"scope": "machine", "target": m, "limits": {"drift_um": 5.0}});
    let (s, p) = run.api("POST", "/api/v1/tolerances", Some(&profile)).await;
    assert_eq!(s, StatusCode::CREATED, "{p}");
    let up = match kind {
        Kind::Session => session_upload(seed, &m, over),
        Kind::Positioning => positioning_upload(seed, over),
        Kind::Cradle => cradle_upload(seed, &m, over),
        Kind::Drift => drift_upload(seed, over),
    };
    let case = format!("seed {seed} ({})", up.what.join(", "));
    let before = run.counts(&m).await;
    let req = request(
        "POST",
        &format!("/api/v1/machines/{m}/datasets"),
        "multipart/form-data; boundary=mtcal-b",
        None,
        multipart(&up.files),
        Some(&run.keys.write),
    );
    let (s, b) = crate::common::send(&run.app, req).await;
    run.checks += 1;
    if s.is_client_error() {
        if up.over.is_none() {
            run.failures
                .push(format!("{case}: within the bounds, refused: {s} {b:.300}"));
        }
        let after = run.counts(&m).await;
        if after != before {
            run.failures.push(format!(
                "{case}: refused ({s} {b:.200}) but stored: (datasets, jobs) {before:?} -> {after:?}"
            ));
        }
        return false;
    }
    if s != StatusCode::CREATED {
        run.failures.push(format!("{case}: upload: {s} {b:.300}"));
        return false;
    }
    if let Some(field) = up.over {
        run.failures
            .push(format!("{case}: {field} beyond its bound, accepted"));
    }
    let dataset = b["id"].as_str().unwrap().to_string();
    let (mut jobs, mut results) = (vec![], vec![]);
    for kind in up.kind.jobs() {
        let (job, result) = run
            .job(&case, json!({"kind": kind, "dataset_id": dataset}))
            .await;
        jobs.push(job);
        *run.made.entry(format!("{:?}", up.kind)).or_default() += usize::from(result.is_some());
        results.extend(result);
    }
    if first {
        let params = json!({"machine": {"template": "vmc3"}});
        let sensitivity = json!({"kind": "sensitivity", "machine_id": m, "params": params});
        let (job, result) = run.job(&case, sensitivity).await;
        jobs.push(job);
        results.extend(result);
    }
    let ids = Ids {
        machine: m.clone(),
        dataset,
        profile: p["id"].as_str().unwrap().to_string(),
        site: "prop".into(),
        ..missing()
    };
    read_everything(run, &case, &ids, &jobs, &results, &up.files).await;
    true
}

/// Every GET route of the API and every page, filled with `ids` (each result and job
/// in turn where the route names one), every export format, each file of the dataset.
async fn read_everything(
    run: &mut Run,
    case: &str,
    ids: &Ids,
    jobs: &[String],
    results: &[String],
    files: &Files,
) {
    let api = Auth::Key(run.keys.admin.clone());
    let page = run.page.clone();
    let with = |result: Option<&String>, job: Option<&String>| Ids {
        result: result.cloned().unwrap_or_else(|| missing().result),
        job: job.cloned().unwrap_or_else(|| missing().job),
        ..ids.clone()
    };
    let mut uris: Vec<(bool, String)> = vec![];
    let templates = api_routes()
        .into_iter()
        .map(|r| (true, r))
        .chain(page_routes().into_iter().map(|r| (false, r)));
    for (is_api, (method, template)) in templates {
        if method != "GET" || template.starts_with("/static/") || template == "/signin" {
            continue;
        }
        if template.contains("/results/{") {
            for r in results {
                uris.push((is_api, fill(&template, &with(Some(r), None))));
            }
        } else if template.contains("/jobs/{") {
            for j in jobs {
                uris.push((is_api, fill(&template, &with(None, Some(j)))));
            }
        } else {
            uris.push((is_api, fill(&template, &with(results.first(), None))));
        }
    }
    let m = &ids.machine;
    for r in results {
        for f in EXPORT_FORMATS {
            uris.push((true, format!("/api/v1/results/{r}/export?format={f}")));
            uris.push((
                true,
                format!("/api/v1/results/{r}/export?format={f}&force=true"),
            ));
        }
        uris.push((false, format!("/compare?a={}&b={r}", results[0])));
    }
    for (name, _) in files {
        uris.push((
            true,
            format!("/api/v1/datasets/{}/files/{name}", ids.dataset),
        ));
    }
    uris.push((
        true,
        format!("/api/v1/machines/{m}/trends/term?term=EXX&at=0"),
    ));
    uris.push((true, format!("/api/v1/machines/{m}/results/diff")));
    uris.push((true, format!("/api/v1/fleet?site={}", ids.site)));
    for (is_api, uri) in uris {
        run.read(case, if is_api { &api } else { &page }, &uri)
            .await;
    }
}

#[tokio::test]
async fn every_accepted_upload_reads_back_on_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    let url = format!("sqlite://{}", dir.path().join("p.sqlite").display());
    let start = Instant::now();
    let t = property(&url).await;
    eprintln!(
        "accepted-upload property on SQLite: {} cases, {} accepted, {} jobs, {} reads, no 5xx, {:.1} s",
        t.cases,
        t.accepted,
        t.jobs,
        t.reads,
        start.elapsed().as_secs_f64()
    );
}

#[tokio::test]
async fn every_accepted_upload_reads_back_on_postgres() {
    let name = "every_accepted_upload_reads_back_on_postgres";
    let Some(pg) = mtcal_store::testing::ScratchPg::create(name).await.unwrap() else {
        eprintln!("{name}: skipped (MTCAL_TEST_PG is not set)");
        return;
    };
    let start = Instant::now();
    let t = property(&pg.url).await;
    eprintln!(
        "accepted-upload property on PostgreSQL: {} cases, {} accepted, {} jobs, {} reads, no 5xx, {:.1} s",
        t.cases,
        t.accepted,
        t.jobs,
        t.reads,
        start.elapsed().as_secs_f64()
    );
    pg.drop_schema().await.unwrap();
}
