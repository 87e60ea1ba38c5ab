//! `mtcal demo`: the service on a fresh SQLite file, a small simulated fleet whose machines
//! drift between quarterly checks, and the URLs to look at.
//!
//! Sessions come from a small generator of this module ([`write_session`]): known
//! polynomial errors ([`PolyErrors`]) through the exact kinematic chain
//! (`mtcal_solver::kinematics::exact_error_um`), plus white noise. It is to be replaced by
//! `mtcal_solver::simulate` when that lands.

use super::submit::Client;
use anyhow::Context;
use mtcal_solver::axis::{Plane, Topology};
use mtcal_solver::basis::PolyErrors;
use mtcal_solver::kinematics::exact_error_um;
use mtcal_solver::terms::{Term, TermKind};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::json;
use std::fmt::Write as _;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

#[derive(clap::Args)]
pub struct Args {
    /// SQLite file to create (deleted first if it exists); default: a fresh temporary file.
    #[arg(long)]
    pub db: Option<PathBuf>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub listen: SocketAddr,
    /// Machines in the fleet.
    #[arg(long, default_value_t = 6)]
    pub machines: usize,
    /// Quarterly checks per machine.
    #[arg(long, default_value_t = 4)]
    pub checks: usize,
    /// Set the fleet up, print the URLs and exit instead of serving on.
    #[arg(long)]
    pub exit: bool,
    /// Only write one generated session folder here (test data), then exit.
    #[arg(long, hide = true)]
    pub write_session: Option<PathBuf>,
    /// With --write-session: machine id, drift seed and quarter.
    #[arg(long, hide = true, default_value = "VMC-0001")]
    pub machine: String,
    #[arg(long, hide = true, default_value_t = 1)]
    pub seed: u64,
    #[arg(long, hide = true, default_value_t = 0)]
    pub quarter: usize,
}

/// Travel of every axis of the demo machines, mm.
const TRAVEL_MM: f64 = 100.0;

/// Normal deviate by Box–Muller.
fn gauss(rng: &mut StdRng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Errors of demo machine `seed` at check `quarter`: a fixed machine signature plus
/// drift growing linearly with time (positioning of X, straightness EYX, squareness
/// EC0Y), at a rate that differs between machines.
pub fn machine_errors(seed: u64, quarter: usize) -> PolyErrors {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut e = PolyErrors::default();
    for t in Term::all() {
        let c = match t.kind() {
            TermKind::Positioning => vec![
                0.02 * gauss(&mut rng),
                1e-5 * gauss(&mut rng),
                1e-7 * gauss(&mut rng),
            ],
            TermKind::Straightness => vec![0.0, 2e-4 * gauss(&mut rng), 1e-6 * gauss(&mut rng)],
            _ => vec![0.05 * gauss(&mut rng), 1e-4 * gauss(&mut rng), 0.0],
        };
        e.set(t, c);
    }
    e.squareness.ec0y_urad = 20.0 * gauss(&mut rng);
    e.squareness.eb0z_urad = 15.0 * gauss(&mut rng);
    e.squareness.ea0z_urad = 15.0 * gauss(&mut rng);
    let rate = 0.5 + 2.0 * rng.random::<f64>();
    let q = quarter as f64 * rate;
    e.coefficients.get_mut("EXX").expect("set above")[0] += 0.005 * q;
    e.coefficients.get_mut("EYX").expect("set above")[1] += 3e-5 * q;
    e.squareness.ec0y_urad += 3.0 * q;
    e
}

/// Writes a session folder: XY at two tool lengths, XZ and YZ; in each, lines along u
/// (at v = 0 and v = 50 mm), along v, and a circle each way of radius 50 mm; noise σ =
/// `noise_um`.
pub fn write_session(
    dir: &Path,
    machine_id: &str,
    measured_at: &str,
    errors: &PolyErrors,
    noise_um: f64,
    seed: u64,
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    let topo = Topology::default();
    let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed);
    let planes = [
        ("xy_L100.csv", Plane::XY, [0.0, 0.0, -100.0], "xy-1"),
        ("xy_L200.csv", Plane::XY, [0.0, 0.0, -200.0], "xy-2"),
        ("xz_L100.csv", Plane::XZ, [0.0, 0.0, -100.0], "xz-1"),
        ("yz_L100.csv", Plane::YZ, [0.0, 0.0, -100.0], "yz-1"),
    ];
    let mut t_s = 0.0;
    let mut listed = Vec::new();
    for (file, plane, offset, mounting) in planes {
        let (u, v) = plane.axes();
        let mut csv = String::from("run,test,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n");
        let mut paths: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
        let line = |from: (f64, f64), to: (f64, f64)| -> Vec<(f64, f64)> {
            (0..=80)
                .map(|i| {
                    let s = i as f64 / 80.0;
                    (from.0 + s * (to.0 - from.0), from.1 + s * (to.1 - from.1))
                })
                .collect()
        };
        let r = TRAVEL_MM;
        paths.push((format!("line_{}", u.letter()), line((-r, 0.0), (r, 0.0))));
        paths.push((
            format!("line_{}", u.letter()),
            line((r, r / 2.0), (-r, r / 2.0)),
        ));
        paths.push((format!("line_{}", v.letter()), line((0.0, -r), (0.0, r))));
        for (name, sign) in [("circle_ccw", 1.0), ("circle_cw", -1.0)] {
            let pts = (0..=144)
                .map(|i| {
                    let a = sign * std::f64::consts::TAU * i as f64 / 144.0;
                    (r / 2.0 * a.cos(), r / 2.0 * a.sin())
                })
                .collect();
            paths.push((name.to_string(), pts));
        }
        for (run, (test, pts)) in paths.iter().enumerate() {
            for &(pu, pv) in pts {
                let mut q = [0.0; 3];
                q[u.index()] = pu;
                q[v.index()] = pv;
                let e = exact_error_um(&topo, errors, q, offset);
                let du = e[u.index()] + noise_um * gauss(&mut rng);
                let dv = e[v.index()] + noise_um * gauss(&mut rng);
                writeln!(
                    csv,
                    "{},{test},{t_s:.3},{:.4},{:.4},{:.4},{du:.5},{dv:.5}",
                    run + 1,
                    q[0],
                    q[1],
                    q[2]
                )?;
                t_s += 0.05;
            }
            t_s += 1.0;
        }
        std::fs::write(dir.join(file), csv)?;
        listed.push(json!({"file": file, "plane": plane.name(), "head_offset_mm": offset, "mounting": mounting}));
    }
    let session = json!({
        "machine_id": machine_id,
        "measured_at": measured_at,
        "topology": {"workpiece": ["X", "Y"], "tool": ["Z"]},
        "temperature_c": 20.0,
        "notes": "generated by mtcal demo",
        "planes": listed,
    });
    std::fs::write(
        dir.join("session.json"),
        serde_json::to_string_pretty(&session)?,
    )?;
    Ok(())
}

/// Measurement time of quarterly check `quarter` (from 2026-01-05).
pub fn check_time(quarter: usize) -> String {
    let month = 1 + 3 * (quarter % 4);
    let year = 2026 + quarter / 4;
    format!("{year}-{month:02}-05T08:00:00Z")
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(dir) = &args.write_session {
        let e = machine_errors(args.seed, args.quarter);
        write_session(
            dir,
            &args.machine,
            &check_time(args.quarter),
            &e,
            0.1,
            args.seed,
        )?;
        return Ok(ExitCode::SUCCESS);
    }
    super::serve::init_logging();
    let db = match &args.db {
        Some(p) => p.clone(),
        None => std::env::temp_dir()
            .join(format!("mtcal-demo-{}", std::process::id()))
            .join("demo.sqlite"),
    };
    if let Some(parent) = db.parent() {
        std::fs::create_dir_all(parent)?;
    }
    for ext in ["", "-wal", "-shm"] {
        let _ = std::fs::remove_file(format!("{}{ext}", db.display()));
    }
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(demo(args, db))
}

async fn demo(args: Args, db: PathBuf) -> anyhow::Result<ExitCode> {
    let db_url = db.display().to_string();
    let store = mtcal_store::open(&db_url).await?;
    let (_, key) = store.create_key(mtcal_store::Scope::Admin, "demo").await?;
    drop(store);
    let serve = super::serve::Args {
        db: db_url.clone(),
        listen: args.listen,
        concurrency: 2,
        lease_ms: 30_000,
        max_attempts: 3,
        max_upload_bytes: 256 << 20,
        no_worker: false,
        pause_before_solve_ms: 0,
    };
    let (tx, rx) = tokio::sync::oneshot::channel();
    let server = tokio::spawn(mtcal_server::serve(serve.config(), move |a| {
        let _ = tx.send(a);
    }));
    let addr = rx.await.context("the service did not start")?;
    let base = format!("http://{addr}");
    let c = Client::new(&base, &key);
    let work = tempfile_dir(&db)?;
    let mut jobs = Vec::new();
    for m in 0..args.machines {
        let id = format!("VMC-{:04}", m + 1);
        c.post(
            "/api/v1/machines",
            &json!({"id": id, "name": format!("Vertical machining centre {}", m + 1),
                    "site": if m % 2 == 0 { "plant-north" } else { "plant-south" },
                    "tags": ["vmc", "demo"],
                    "travel_mm": {"X": [-TRAVEL_MM, TRAVEL_MM], "Y": [-TRAVEL_MM, TRAVEL_MM], "Z": [-TRAVEL_MM, TRAVEL_MM]}}),
        )
        .await?;
        for q in 0..args.checks {
            let dir = work.join(format!("{id}-q{q}"));
            write_session(
                &dir,
                &id,
                &check_time(q),
                &machine_errors(m as u64 + 1, q),
                0.1,
                (m * 100 + q) as u64,
            )?;
            let ds = c.upload_session(&id, &dir).await?;
            let job = c
                .post(
                    "/api/v1/jobs",
                    &json!({"kind": "identify", "dataset_id": ds["id"]}),
                )
                .await?;
            jobs.push(job["id"].as_str().unwrap_or_default().to_string());
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    eprintln!("running {} identification jobs …", jobs.len());
    let (mut ok, mut failed) = (0, Vec::new());
    for j in &jobs {
        let job = c.wait_job(j, Duration::from_secs(600), |_, _| {}).await?;
        if job["state"] == "succeeded" {
            ok += 1;
        } else {
            failed.push(format!(
                "{j}: {}",
                job["error_message"].as_str().unwrap_or("")
            ));
        }
    }
    println!(
        "mtcal demo: {} machines, {ok}/{} identifications succeeded",
        args.machines,
        jobs.len()
    );
    for f in failed.iter().take(3) {
        println!("  failed {f}");
    }
    println!("database:      {}", db.display());
    println!("API key:       {key}   (export MTCAL_API_KEY={key})");
    println!("Swagger UI:    {base}/docs");
    println!("OpenAPI:       {base}/api-docs/openapi.json");
    println!("fleet drift:   curl -H 'Authorization: Bearer {key}' {base}/api/v1/fleet/drift");
    println!(
        "history:       curl -H 'Authorization: Bearer {key}' {base}/api/v1/machines/VMC-0001/results"
    );
    println!(
        "EXX at ±50 mm: curl -H 'Authorization: Bearer {key}' '{base}/api/v1/machines/VMC-0001/trends/term?term=EXX&at=-50,50'"
    );
    println!(
        "vs baseline:   curl -H 'Authorization: Bearer {key}' {base}/api/v1/machines/VMC-0001/results/diff"
    );
    if args.exit {
        server.abort();
        return Ok(if failed.is_empty() {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        });
    }
    println!("serving; Ctrl-C to stop");
    server.await??;
    Ok(ExitCode::SUCCESS)
}

fn tempfile_dir(db: &Path) -> anyhow::Result<PathBuf> {
    let d = db.with_extension("sessions");
    std::fs::create_dir_all(&d)?;
    Ok(d)
}
