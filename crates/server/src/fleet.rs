//! The fleet's drift since each machine's baseline, maintained instead of recomputed per
//! request: when an identification result lands (the worker), when a machine's baseline
//! changes (`PATCH`), and once for every machine when `mtcal serve` starts (results
//! stored by an older version or imported in bulk). `GET /api/v1/fleet/drift` and the
//! fleet page read the stored rows, ranked by the database.
//!
//! Concurrency: each row records when the state it was computed from was read; the store
//! keeps the row from the latest read, so two workers finishing results of one machine at
//! once cannot leave the earlier computation in place.

use crate::api::history::KIND;
use crate::api::trends::FleetEntry;
use crate::trends;
use mtcal_store::{FleetDriftRow, Machine, ResultMeta, Store, StoreError, now_ms};

fn row(
    read_at_ms: i64,
    machine: &Machine,
    baseline: &ResultMeta,
    latest: &ResultMeta,
    results: i64,
) -> Result<FleetDriftRow, StoreError> {
    let entry = FleetEntry {
        drift: trends::drift(&baseline.scalars, &latest.scalars),
        machine_id: machine.id.clone(),
        name: machine.name.clone(),
        site: machine.site.clone(),
        baseline_result_id: baseline.id.clone(),
        latest_result_id: latest.id.clone(),
        latest_measured_at: latest.measured_at.clone(),
        results,
    };
    Ok(FleetDriftRow {
        machine_id: machine.id.clone(),
        read_at_ms,
        drift_um: entry.drift.drift_um,
        drift_urad: entry.drift.drift_urad,
        entry: serde_json::to_value(&entry).map_err(|e| StoreError::Backend(e.to_string()))?,
    })
}

/// Recomputes and stores machine `id`'s drift (its baseline: the chosen one, else its
/// first identification; against its latest).
pub async fn refresh_machine(store: &dyn Store, id: &str) -> Result<(), StoreError> {
    let read_at = now_ms();
    let machine = store.get_machine(id).await?;
    let results = store.list_results(id, KIND).await?;
    let (Some(first), Some(latest)) = (results.first(), results.last()) else {
        return store.delete_fleet_drift(id).await;
    };
    let baseline = machine
        .baseline_result_id
        .as_ref()
        .and_then(|b| results.iter().find(|r| &r.id == b))
        .unwrap_or(first);
    let r = row(read_at, &machine, baseline, latest, results.len() as i64)?;
    store.put_fleet_drift(&r).await.map(|_| ())
}

/// Recomputes every machine's drift (one read of all baseline/latest pairs); returns how
/// many machines have one.
pub async fn refresh_all(store: &dyn Store) -> Result<usize, StoreError> {
    let read_at = now_ms();
    let pairs = store.baseline_pairs(KIND).await?;
    for p in &pairs {
        store
            .put_fleet_drift(&row(
                read_at,
                &p.machine,
                &p.baseline,
                &p.latest,
                p.results,
            )?)
            .await?;
    }
    Ok(pairs.len())
}
