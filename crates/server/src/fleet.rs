//! The fleet's drift since each machine's baseline, maintained instead of recomputed per
//! request: when an identification result lands (the worker), when a machine's baseline
//! changes (`PATCH`), and once for every machine when `mtcal serve` starts (results
//! stored by an older version or imported in bulk). `GET /api/v1/fleet/drift` and the
//! fleet page read the stored rows, ranked by the database.
//!
//! Each row also carries the latest result's verdict against the machine's tolerance
//! profile ([`crate::tolerances`]); a profile's change refreshes the machines it applies
//! to ([`refresh_profile_targets`]). When an identification lands the drift alert check
//! runs here too ([`result_landed`], [`crate::alerts`]).
//!
//! Concurrency: each row records when the state it was computed from was read; the store
//! keeps the row from the latest read, so two workers finishing results of one machine at
//! once cannot leave the earlier computation in place.

use crate::api::history::KIND;
use crate::api::trends::FleetEntry;
use crate::trends;
use mtcal_store::{
    FleetDriftRow, Machine, ResultMeta, Store, StoreError, ToleranceProfile, now_ms,
};
use std::sync::Arc;

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

/// The baseline among a machine's identifications `results` (time order): its chosen
/// one, else its first.
pub fn baseline<'a>(machine: &Machine, results: &'a [ResultMeta]) -> Option<&'a ResultMeta> {
    machine
        .baseline_result_id
        .as_ref()
        .and_then(|b| results.iter().find(|r| &r.id == b))
        .or(results.first())
}

/// Machine `machine`'s row from its identifications `results` (time order, not empty).
async fn row(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    read_at_ms: i64,
    machine: &Machine,
    results: &[ResultMeta],
) -> Result<Option<FleetDriftRow>, StoreError> {
    let (Some(baseline), Some(latest)) = (baseline(machine, results), results.last()) else {
        return Ok(None);
    };
    // The latest result's document is read only when a profile applies. A document that
    // cannot be judged leaves the verdict out, never the drift.
    let verdict = match crate::tolerances::applicable(profiles, machine) {
        Some(_) => {
            let r = store.get_result(&latest.id).await?;
            crate::tolerances::verdict(store, profiles, machine, &r)
                .await
                .unwrap_or_else(|e| {
                    tracing::warn!(result = %latest.id, %e, "no verdict for the fleet row");
                    None
                })
        }
        None => None,
    };
    let drift = trends::drift(&baseline.scalars, &latest.scalars);
    let entry = FleetEntry {
        verdict: verdict.as_ref().and_then(|(_, v)| v.decision),
        tolerance_profile_id: verdict.map(|(p, _)| p.id),
        sparkline: sparkline(results, latest, drift.worst_term_um.as_deref()),
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
        entry: serde_json::to_value(&entry).map_err(|e| StoreError::Backend(e.to_string()))?,
        latest_measured_at: Some(latest.measured_at.clone()),
    }))
}

/// Recomputes and stores one machine's row against `profiles`.
async fn refresh_with(
    store: &dyn Store,
    profiles: &[ToleranceProfile],
    id: &str,
) -> Result<(), StoreError> {
    let read_at = now_ms();
    let machine = store.get_machine(id).await?;
    let results = store.list_results(id, KIND).await?;
    match row(store, profiles, read_at, &machine, &results).await? {
        Some(r) => store.put_fleet_drift(&r).await.map(|_| ()),
        None => store.delete_fleet_drift(id).await,
    }
}

/// Recomputes and stores machine `id`'s drift (its baseline: the chosen one, else its
/// first identification; against its latest).
pub async fn refresh_machine(store: &dyn Store, id: &str) -> Result<(), StoreError> {
    let profiles = store.list_tolerances().await?;
    refresh_with(store, &profiles, id).await
}

/// Recomputes every machine's row (each machine's checks read once: the sparkline needs
/// them all); returns how many machines have one.
pub async fn refresh_all(store: &dyn Store) -> Result<usize, StoreError> {
    let pairs = store.baseline_pairs(KIND).await?;
    let profiles = store.list_tolerances().await?;
    for p in &pairs {
        refresh_with(store, &profiles, &p.machine.id).await?;
    }
    Ok(pairs.len())
}

/// An identification `result_id` of machine `machine_id` has landed: its drift row is
/// refreshed, then the drift alert check runs ([`crate::alerts::check_landed`]).
pub async fn result_landed(
    store: &Arc<dyn Store>,
    machine_id: &str,
    result_id: &str,
) -> Result<Option<crate::alerts::AlertView>, StoreError> {
    refresh_machine(store.as_ref(), machine_id).await?;
    crate::alerts::check_landed(store, machine_id, result_id).await
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
