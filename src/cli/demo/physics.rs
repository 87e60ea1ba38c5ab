//! The demo's machines whose checks carry physics the 21-term model lacks, each showing
//! one way a misfit ends:
//!
//! | machine | checks (oldest first) | what the demo shows |
//! |---|---|---|
//! | [`WORN_MACHINE`] | clean; 6 µm backlash of X; a month later, 0.4 µm left after compensation (also diagnosed) | a misfit decided on its explained model, its actions and LinuxCNC table; the later check verified against the prediction |
//! | [`WARM_NUT_MACHINE`] | clean; a lost motion of X widening from 2 to 8 µm and back to 2 µm over the session (a half sine in time) | a misfit only partly explained: not decided, marked in the fleet and the trends |
//!
//! Every session is the full plan at 5 Hz (as the fleet's), so the whole set costs a few
//! identifications and three diagnoses.

use super::{TRAVEL_MM, check_time, machine_errors};
use anyhow::Context;
use mtcal_client::Client;
use mtcal_server::api::jobs::SubmitJob;
use mtcal_server::api::machines::NewMachine;
use mtcal_server::jobs::JobKind;
use mtcal_solver::axis::Axis;
use mtcal_solver::diagnosis::{DiagnosisResult, Verdict};
use mtcal_solver::identification::IdentificationResult;
use mtcal_solver::session::Session;
use mtcal_solver::simulate::{Effect, Plan, SimOptions, simulate};
use serde_json::json;
use std::path::Path;

/// Demo machine whose X screw has worn: its second check was recorded with a 6 µm
/// backlash of X that the rigid model lacks (a misfit the service diagnoses on its own and
/// decides on the explained model); its third, a month later, after the backlash
/// compensation was set, with 0.4 µm left.
pub const WORN_MACHINE: &str = "VMC-0900";

/// Demo machine whose latest check stays not decided: its X nut's play widens as it warms
/// and narrows again as it cools within the session, which neither a constant backlash nor
/// a steady growth explains (the diagnosis explains it only partly).
pub const WARM_NUT_MACHINE: &str = "VMC-0901";

/// The machines the demo waits for until their misfits are diagnosed and explained.
pub const MISFIT_MACHINES: [&str; 2] = [WORN_MACHINE, WARM_NUT_MACHINE];

/// Lost motion of X put into the worn machine's misfit check, µm.
const WORN_BACKLASH_UM: f64 = 6.0;

/// Lost motion of X left after the compensation was set, µm.
const LEFT_BACKLASH_UM: f64 = 0.4;

/// The warm nut's play of X at the session's start and end, µm, and its widening at
/// mid-session, µm.
const WARM_NUT_UM: (f64, f64) = (2.0, 6.0);

/// Registers both machines and uploads and submits their checks (the last quarterly
/// check `checks - 1` is the misfit); the jobs submitted.
pub async fn seed(c: &Client, work: &Path, checks: usize) -> anyhow::Result<Vec<String>> {
    let last = checks.max(2) - 1;
    let mut jobs = vec![];
    register(
        c,
        WORN_MACHINE,
        "Vertical machining centre, worn X screw",
        "plant-south",
    )
    .await?;
    let backlash = |um: f64| Effect::Backlash {
        axis: Axis::X,
        lost_motion_um: um,
    };
    for (q, effects, at) in [
        (last - 1, vec![], check_time(last - 1)),
        (last, vec![backlash(WORN_BACKLASH_UM)], check_time(last)),
        (
            last + 1,
            vec![backlash(LEFT_BACKLASH_UM)],
            month_after(last),
        ),
    ] {
        let session = simulated(WORN_MACHINE, 900, q, effects, &at)?;
        let ds = upload(c, work, WORN_MACHINE, q, &session).await?;
        jobs.push(submit(c, JobKind::Identify, &ds).await?);
        // The check after compensation is diagnosed too (the dashboard's "also
        // diagnose"): its model explains its recording, and the diagnosis measures the
        // lost motion left, which the verification compares with the prediction.
        if q > last {
            jobs.push(submit(c, JobKind::Diagnose, &ds).await?);
        }
    }
    register(
        c,
        WARM_NUT_MACHINE,
        "Vertical machining centre, X nut warming up",
        "plant-north",
    )
    .await?;
    for q in [last - 1, last] {
        let mut session = simulated(WARM_NUT_MACHINE, 901, q, vec![], &check_time(q))?;
        if q == last {
            warming_play(&mut session, Axis::X, WARM_NUT_UM.0, WARM_NUT_UM.1);
        }
        let ds = upload(c, work, WARM_NUT_MACHINE, q, &session).await?;
        jobs.push(submit(c, JobKind::Identify, &ds).await?);
    }
    Ok(jobs)
}

/// Registers demo machine `id` (tagged `vmc`, the demo's travel) at `site`.
async fn register(c: &Client, id: &str, name: &str, site: &str) -> anyhow::Result<()> {
    c.create_machine(&NewMachine {
        id: id.into(),
        name: name.into(),
        topology: None,
        travel_mm: ["X", "Y", "Z"]
            .map(|a| (a.to_string(), [-TRAVEL_MM, TRAVEL_MM]))
            .into(),
        site: Some(site.into()),
        tags: vec!["vmc".into(), "demo".into()],
    })
    .await?;
    Ok(())
}

/// A check of machine `id` (errors of demo seed `seed` at quarter `q`) with `effects`.
fn simulated(
    id: &str,
    seed: u64,
    q: usize,
    effects: Vec<Effect>,
    measured_at: &str,
) -> anyhow::Result<Session> {
    let sim = simulate(
        &machine_errors(seed, q),
        &SimOptions {
            seed: seed + q as u64,
            noise_um: 0.1,
            plan: Plan::Full,
            sample_rate_hz: 5.0,
            machine_id: id.into(),
            measured_at: measured_at.into(),
            effects,
            ..SimOptions::default()
        },
    )
    .with_context(|| format!("simulating a session of {id}"))?;
    Ok(sim.session)
}

async fn upload(
    c: &Client,
    work: &Path,
    id: &str,
    q: usize,
    session: &Session,
) -> anyhow::Result<String> {
    let dir = work.join(format!("{id}-q{q}"));
    mtcal_formats::write_session_dir(&dir, session)?;
    Ok(c.upload_path(id, &dir).await?.id)
}

async fn submit(c: &Client, kind: JobKind, dataset_id: &str) -> anyhow::Result<String> {
    let job = c
        .submit(&SubmitJob {
            kind,
            dataset_id: Some(dataset_id.into()),
            machine_id: None,
            params: json!({}),
        })
        .await?;
    Ok(job.id)
}

/// The measurement time a month after quarterly check `quarter`.
fn month_after(quarter: usize) -> String {
    let month = 2 + 3 * (quarter % 4);
    let year = 2026 + quarter / 4;
    format!("{year}-{month:02}-05T08:00:00Z")
}

/// Adds to `session` the play of `axis`'s nut warming and cooling again: a lost motion of
/// `from_um` at the session's start and end, `rise_um` wider at its middle (a half sine in
/// time). The nut follows the axis with that clearance (taken up at each reversal, in time
/// order over every file), and the error along the axis is the nut's lag behind the
/// commanded position. Neither a constant backlash nor a steady growth follows it, so its
/// check stays a misfit the diagnosis explains only partly.
fn warming_play(session: &mut Session, axis: Axis, from_um: f64, rise_um: f64) {
    let a = axis.index();
    let mut samples: Vec<(f64, usize, usize, usize)> = vec![];
    for (p, plane) in session.planes.iter().enumerate() {
        for (r, run) in plane.runs.iter().enumerate() {
            samples.extend(run.t_s.iter().enumerate().map(|(i, t)| (*t, p, r, i)));
        }
    }
    samples.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (t0, t1) = match (samples.first(), samples.last()) {
        (Some(a), Some(b)) if b.0 > a.0 => (a.0, b.0),
        _ => return,
    };
    let mut nut: Option<f64> = None;
    for (t, p, r, i) in samples {
        let plane = &mut session.planes[p];
        let (u, v) = plane.plane.axes();
        let run = &mut plane.runs[r];
        let q = run.pos_mm[i][a];
        let warm = (std::f64::consts::PI * (t - t0) / (t1 - t0)).sin();
        let half = (from_um + rise_um * warm) * 1e-3 / 2.0;
        let at = nut
            .unwrap_or(q - from_um * 1e-3 / 2.0)
            .clamp(q - half, q + half);
        nut = Some(at);
        let e = (at - q) * 1e3;
        if u == axis {
            run.du_um[i] += e;
        } else if v == axis {
            run.dv_um[i] += e;
        }
    }
}

/// Whether the service is done with `machine`'s misfits: every check in its history
/// whose model does not explain its recording (and is not itself an explained model)
/// has its diagnosis, and that diagnosis explains nothing (one that does would have its
/// explained model stored in the check's place).
pub async fn settled(c: &Client, machine: &str) -> anyhow::Result<bool> {
    let diagnoses = c.results(machine, Some("diagnosis")).await?;
    for r in c.results(machine, Some("identification")).await? {
        if r.excluded.is_some() {
            continue;
        }
        let Ok(doc) =
            serde_json::from_value::<IdentificationResult>(c.result(&r.id).await?.document)
        else {
            continue;
        };
        if !doc.model_check().is_misfit() || doc.explained.is_some() {
            continue;
        }
        let Some(d) = diagnoses
            .iter()
            .rev()
            .find(|d| d.dataset_id == r.dataset_id)
        else {
            return Ok(false);
        };
        let d: DiagnosisResult = serde_json::from_value(c.result(&d.id).await?.document)?;
        if matches!(d.verdict, Verdict::Explained | Verdict::PartlyExplained)
            && !d.findings.is_empty()
        {
            return Ok(false);
        }
    }
    Ok(true)
}
