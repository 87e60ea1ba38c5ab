//! The fleet's drift since each machine's baseline, maintained instead of recomputed per
//! request: when an identification result lands (the worker), when a machine's baseline
//! changes (`PATCH`), and once for every machine when `mtcal serve` starts (results
//! stored by an older version or imported in bulk). `GET /api/v1/fleet/drift` and
//! `GET /api/v1/fleet` (the fleet page's route, the module `page`) read the stored
//! rows, ranked by the database.
//!
//! Each row also carries the latest result's verdict against the machine's tolerance
//! profile ([`crate::verdicts`]); a profile's change refreshes the machines it applies
//! to ([`refresh_profile_targets`]). When an identification lands its row is refreshed
//! before the drift alert check runs (the module `landing`). The row also says whether
//! the latest check's model explains its recording (its misfit gate) and what the
//! diagnosis of that recording found; a diagnosis landing refreshes the row too
//! (`landing::diagnosis_landed`), so the basis need not name it.
//!
//! Concurrency: each row records when the state it was computed from was read; the store
//! keeps the row from the latest read, so two workers finishing results of one machine at
//! once cannot leave the earlier computation in place; likewise a removal (the machine
//! read without an identification, by a profile's refresh say) leaves a row from a later
//! read (a result that landed meanwhile) in place.
//!
//! Each row also names its basis ([`basis`]: the row format, the baseline and latest
//! results, the number of results, the tolerance profile and its revision). The refresh
//! at start compares it with the basis the machine has now and recomputes only the rows
//! that differ, so a restart costs one query a batch of machines over the fleet, not a
//! read of every check.

use crate::fleet::entry::{DiagnosisSummary, FleetEntry};
use crate::history::baseline_among;
use crate::kinds::IDENTIFICATION;
use crate::trends;
use mtcal_store::{
    EntryJson, FleetDriftRow, Machine, ResultMeta, Store, StoreError, ToleranceProfile, now_ms,
};
use std::collections::HashMap;

/// The format of the rows this version computes: raised whenever what a row holds or how
/// it is computed changes, so that rows of an older computation are recomputed at start.
pub const ROW_FORMAT: u32 = 5;

/// Machines walked, and rows written per transaction, by [`refresh_all`] at a time.
const REFRESH_BATCH: usize = 500;

/// What a machine's row is computed from: the row format ([`ROW_FORMAT`]), its baseline
/// and latest results, how many results it has (a result added or excluded changes the
/// sparkline) and the tolerance profile that applies with its revision (`updated_at`),
/// or none. Two equal bases give equal rows.
pub fn basis(
    baseline_id: &str,
    latest_id: &str,
    results: usize,
    profile: Option<&ToleranceProfile>,
) -> String {
    let profile = profile.map_or_else(String::new, |p| format!("{}@{}", p.id, p.updated_at));
    format!("v{ROW_FORMAT} {baseline_id} {latest_id} {results} {profile}")
}

/// The fleet page's sparkline of a machine: its worst translational term's value in each
/// check, in time order, at the end of the latest check's measured travel (of the term's
/// axis) where it changed more; null where a check did not identify the term or did not
/// measure that position (nothing is extrapolated, as in the term trend route).
pub fn sparkline(
    results: &[ResultMeta],
    latest: &ResultMeta,
    term: Option<&str>,
) -> Vec<Option<f64>> {
    let Some((term, (_, axis))) = term.and_then(|t| Some((t, trends::term_info(t)?))) else {
        return vec![];
    };
    let Some([lo, hi]) = trends::measured(&latest.scalars, axis) else {
        return vec![];
    };
    let column = |q: f64| -> Vec<Option<f64>> {
        results
            .iter()
            .map(|r| Some(trends::value(&r.scalars, term, q)?.value))
            .collect()
    };
    let change = |v: &[Option<f64>]| {
        let known: Vec<f64> = v.iter().flatten().copied().collect();
        match (known.first(), known.last()) {
            (Some(a), Some(b)) => (b - a).abs(),
            _ => 0.0,
        }
    };
    let (at_lo, at_hi) = (column(lo), column(hi));
    if change(&at_hi) > change(&at_lo) {
        at_hi
    } else {
        at_lo
    }
}

/// The diagnosis of the recording machine `machine`'s latest check `latest` was
/// identified from (its latest, when there are several), summarised for the row.
async fn latest_check_diagnosis(
    store: &dyn Store,
    machine: &Machine,
    latest: &ResultMeta,
) -> Result<Option<DiagnosisSummary>, StoreError> {
    let Some(dataset) = &latest.dataset_id else {
        return Ok(None);
    };
    let Some(d) = crate::history::diagnosis_of_dataset(store, &machine.id, dataset).await? else {
        return Ok(None);
    };
    let doc = store.get_result(&d.id).await?.document;
    Ok(Some(DiagnosisSummary::of(&d.id, doc)))
}

/// Machine `machine`'s row from its identifications `results` (time order, not empty).
async fn row(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    read_at_ms: i64,
    machine: &Machine,
    results: &[ResultMeta],
) -> Result<Option<FleetDriftRow>, StoreError> {
    let Some(latest) = results.last() else {
        return Ok(None);
    };
    // Every check a misfit: the latest is its own reference (drift 0) until a check
    // whose model explains its recording lands. The checks' models as stored beside
    // them (one statement), a document read only for a model not stored yet.
    let models = trends::check_models(store, results).await?;
    let baseline = baseline_among(machine, results, &models).unwrap_or(latest);
    let profile = crate::profiles::applicable(profiles, machine);
    // The basis names the baseline as the store's pairs do (chosen, else first): the
    // default baseline (the first check that is not a misfit) changes only with the
    // checks listed, which the count and the ends already follow.
    let named = crate::history::chosen_or_first(machine, results);
    let basis = basis(
        &named.unwrap_or(latest).id,
        &latest.id,
        results.len(),
        profile,
    );
    // The latest result's document, read only for what its stored model does not say:
    // a misfit's whole model check, and the verdict when a profile applies. A document
    // that cannot be judged leaves the verdict out, never the drift.
    let model = models.get(&latest.id).cloned().unwrap_or_default();
    let latest_doc = match model.misfit || profile.is_some() {
        true => Some(store.get_result(&latest.id).await?),
        false => None,
    };
    let (misfit, explained_model) = match &latest_doc {
        Some(doc) => {
            let check = trends::model_check(&doc.document);
            let explained = check
                .as_ref()
                .filter(|c| c.decided_on_explained_model())
                .map(|c| c.statement.clone());
            (check.filter(|c| c.is_misfit()), explained)
        }
        None => (None, model.explained_model),
    };
    let verdict = match (profile, &latest_doc) {
        (Some(_), Some(doc)) => crate::verdicts::verdict(store, profiles, machine, doc)
            .await
            .unwrap_or_else(|e| {
                tracing::warn!(result = %latest.id, %e, "no verdict for the fleet row");
                None
            }),
        _ => None,
    };
    let diagnosis = latest_check_diagnosis(store, machine, latest).await?;
    // The arithmetic off the async threads (a machine's every check for the sparkline).
    let (base, checks) = (baseline.scalars.clone(), results.to_vec());
    let (drift, sparkline) = crate::blocking::run::<_, StoreError>(move || {
        let latest = checks.last().expect("not empty");
        let drift = trends::drift(&base, &latest.scalars);
        let line = sparkline(&checks, latest, drift.worst_term_um.as_deref());
        (drift, line)
    })
    .await?;
    let entry = FleetEntry {
        verdict: verdict.as_ref().and_then(|(_, v)| v.decision),
        verdict_summary: verdict
            .as_ref()
            .filter(|(_, v)| v.decision.is_some())
            .map(|(_, v)| crate::fleet::entry::VerdictSummary::of(v)),
        tolerance_profile_id: verdict.map(|(p, _)| p.id),
        misfit,
        explained_model,
        diagnosis,
        sparkline,
        drift,
        machine_id: machine.id.clone(),
        name: machine.name.clone(),
        site: machine.site.clone(),
        baseline_result_id: baseline.id.clone(),
        latest_result_id: latest.id.clone(),
        latest_measured_at: latest.measured_at.clone(),
        results: results.len() as i64,
    };
    Ok(Some(FleetDriftRow {
        machine_id: machine.id.clone(),
        read_at_ms,
        drift_um: entry.drift.drift_um,
        drift_urad: entry.drift.drift_urad,
        entry: EntryJson::new(&entry).map_err(|e| StoreError::Backend(e.to_string()))?,
        latest_measured_at: Some(latest.measured_at.clone()),
        basis: Some(basis),
    }))
}

/// Machine `id`'s row from the machine and its identifications as they are now (read
/// after the row's read time), against `profiles`; without an identification, the read
/// time alone (the row, if any, is to be removed: [`remove`]).
async fn compute(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    id: &str,
) -> Result<Result<FleetDriftRow, i64>, StoreError> {
    let read_at = now_ms();
    let machine = store.get_machine(id).await?;
    let results = store.list_results(id, IDENTIFICATION).await?;
    Ok(row(store, profiles, read_at, &machine, &results)
        .await?
        .ok_or(read_at))
}

/// Removes machine `id`'s row, found without an identification when read at
/// `read_at_ms`, unless a row from a later read (a result that landed meanwhile) was
/// stored since.
async fn remove(store: &dyn Store, id: &str, read_at_ms: i64) -> Result<(), StoreError> {
    store.delete_fleet_drift(id, read_at_ms).await.map(|_| ())
}

/// Recomputes and stores machine `id`'s drift (its baseline: the chosen one, else its
/// first identification; against its latest).
pub async fn refresh_machine(store: &dyn Store, id: &str) -> Result<(), StoreError> {
    let profiles = store.list_tolerances().await?;
    match compute(store, &profiles, id).await? {
        Ok(r) => store.put_fleet_drift(&r).await.map(|_| ()),
        Err(read_at) => remove(store, id, read_at).await,
    }
}

/// How a refresh of the whole fleet went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Refreshed {
    /// Machines with a row (those with an identification).
    pub machines: usize,
    /// Rows recomputed because their basis was not current or their machine had no
    /// identification left (the rest were kept).
    pub recomputed: usize,
}

/// Brings every machine's row up to date, walking the machines by id
/// [`REFRESH_BATCH`] at a time: one query gives each machine's baseline, latest result
/// and result count, and only the rows whose stored [`basis`] differs from the current
/// one are recomputed (each such machine's checks read once: the sparkline needs them
/// all) and written in one transaction a batch. Rows of machines left without an
/// identification are removed. Rows are written from the first batch on, so a refresh
/// of a large fleet stopped midway keeps what it did.
pub async fn refresh_all(store: &dyn Store) -> Result<Refreshed, StoreError> {
    let profiles = store.list_tolerances().await?;
    let mut done = Refreshed {
        machines: 0,
        recomputed: 0,
    };
    let mut after: Option<String> = None;
    loop {
        let batch = store
            .baseline_pairs_after(IDENTIFICATION, after.as_deref(), REFRESH_BATCH)
            .await?;
        let last = batch.machines < REFRESH_BATCH;
        // The stored rows of the batch's machines (and, in the last batch, any after).
        let through = if last { None } else { batch.last.as_deref() };
        let mut stored: HashMap<String, Option<String>> = store
            .fleet_drift_bases(after.as_deref(), through)
            .await?
            .into_iter()
            .collect();
        let mut stale = Vec::new();
        for p in &batch.pairs {
            let profile = crate::profiles::applicable(&profiles, &p.machine);
            let now = basis(
                &p.baseline.id,
                &p.latest.id,
                usize::try_from(p.results).unwrap_or(0),
                profile,
            );
            if stored.remove(&p.machine.id).flatten().as_deref() != Some(now.as_str()) {
                stale.push(p.machine.id.clone());
            }
        }
        // Rows left over belong to machines without an identification when the pairs
        // were read: recomputed too (removed, unless a result landed since).
        stale.extend(stored.into_keys());
        let mut rows = Vec::new();
        for id in &stale {
            match compute(store, &profiles, id).await? {
                Ok(r) => rows.push(r),
                Err(read_at) => remove(store, id, read_at).await?,
            }
        }
        if !rows.is_empty() {
            store.put_fleet_drifts(&rows).await?;
        }
        done.machines += batch.pairs.len();
        done.recomputed += stale.len();
        match batch.last {
            Some(id) if !last => after = Some(id),
            _ => return Ok(done),
        }
    }
}

/// Refreshes the rows of the machines a profile of `scope` on `target` applies to (after
/// it was created, replaced or deleted): the machine, or every machine with the tag.
pub async fn refresh_profile_targets(
    store: &dyn Store,
    scope: &str,
    target: &str,
) -> Result<usize, StoreError> {
    if scope == "machine" {
        return match store.get_machine(target).await {
            Ok(_) => refresh_machine(store, target).await.map(|_| 1),
            Err(StoreError::NotFound(_)) => Ok(0),
            Err(e) => Err(e),
        };
    }
    let mut after: Option<String> = None;
    let mut n = 0;
    loop {
        let page = store.list_machines(after.as_deref(), 1000).await?;
        for m in page.iter().filter(|m| m.tags.iter().any(|t| t == target)) {
            refresh_machine(store, &m.id).await?;
            n += 1;
        }
        match page.last() {
            Some(m) if page.len() == 1000 => after = Some(m.id.clone()),
            _ => return Ok(n),
        }
    }
}
