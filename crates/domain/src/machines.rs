//! Machines: registering one and changing it, with the rules a machine's fields obey
//! (id, topology, travel); the API's machine routes, the dashboard's forms and
//! `mtcal admin create-machine` call these.

use crate::error::DomainError;
pub use mtcal_api::machines::NewMachine;
use mtcal_solver::axis::Topology;
use mtcal_store::{Machine, MachinePatch, Store};
use std::collections::BTreeMap;

/// Checks and normalises a topology given as JSON.
pub fn topology(v: Option<&serde_json::Value>) -> Result<serde_json::Value, DomainError> {
    let t: Topology = match v {
        None => Topology::default(),
        Some(v) => serde_json::from_value(v.clone())
            .map_err(|e| DomainError::Invalid(format!("topology: {e}")))?,
    };
    let mut all: Vec<_> = t.workpiece.iter().chain(&t.tool).collect();
    all.sort();
    all.dedup();
    if all.len() != 3 || t.workpiece.len() + t.tool.len() != 3 {
        return Err(DomainError::Invalid(
            "topology: X, Y and Z must each appear exactly once".into(),
        ));
    }
    Ok(serde_json::to_value(t).expect("topology serialises"))
}

pub use mtcal_store::model::MAX_TRAVEL_MM;

/// Checks a machine's travel per axis.
pub fn check_travel(travel: &BTreeMap<String, [f64; 2]>) -> Result<(), DomainError> {
    for (axis, [lo, hi]) in travel {
        let ordered = lo.is_finite() && hi.is_finite() && lo < hi;
        let bounded = lo.abs() <= MAX_TRAVEL_MM && hi.abs() <= MAX_TRAVEL_MM;
        if !matches!(axis.as_str(), "X" | "Y" | "Z") || !ordered || !bounded {
            return Err(DomainError::Invalid(format!(
                "travel_mm.{axis}: needs axis X, Y or Z and finite [min, max] with min < max \
                 and |min|, |max| <= {MAX_TRAVEL_MM} mm"
            )));
        }
    }
    Ok(())
}

/// Registers machine `m` after checking its fields (the store checks its text fields
/// and refuses an id already taken).
pub async fn create(store: &dyn Store, m: NewMachine) -> Result<Machine, DomainError> {
    mtcal_store::text::check_id("id", &m.id)?;
    check_travel(&m.travel_mm)?;
    let machine = Machine {
        id: m.id,
        name: m.name,
        topology: topology(m.topology.as_ref())?,
        travel_mm: m.travel_mm,
        site: m.site,
        tags: m.tags,
        baseline_result_id: None,
        created_at: String::new(),
        updated_at: String::new(),
    };
    Ok(store.create_machine(&machine).await?)
}

/// Refuses result `id` as a baseline when it is a misfit check: its model does not
/// explain its recording, so nothing measured against it would be decided. A result not
/// found, of another kind or of another machine is left to the store's own check.
async fn refuse_misfit_baseline(
    store: &dyn Store,
    machine: &str,
    id: &str,
) -> Result<(), DomainError> {
    let r = match store.get_result(id).await {
        Ok(r) => r,
        Err(mtcal_store::StoreError::NotFound(_)) => return Ok(()),
        Err(e) => return Err(e.into()),
    };
    if r.meta.kind != crate::kinds::IDENTIFICATION || r.meta.machine_id != machine {
        return Ok(());
    }
    match crate::history::misfit_gate(&r.document) {
        Some(gate) => Err(DomainError::Conflict(format!(
            "result {id} cannot be the baseline: it is a misfit check ({}); choose a check \
             whose model explains its recording",
            gate.statement
        ))),
        None => Ok(()),
    }
}

/// Checks and applies a patch to machine `id`; its fleet row is refreshed when what the
/// row depends on changed (the baseline, the tags that choose its tolerance profile, the
/// name and site its entry repeats).
pub async fn update(
    store: &dyn Store,
    id: &str,
    mut p: MachinePatch,
) -> Result<Machine, DomainError> {
    if let Some(t) = &p.topology {
        p.topology = Some(topology(Some(t))?);
    }
    if let Some(t) = &p.travel_mm {
        check_travel(t)?;
    }
    if let Some(b) = &p.baseline_result_id {
        refuse_misfit_baseline(store, id, b).await?;
    }
    let row_changes =
        p.baseline_result_id.is_some() || p.tags.is_some() || p.name.is_some() || p.site.is_some();
    let m = store.update_machine(id, &p).await?;
    if row_changes {
        crate::fleet::refresh_machine(store, id).await?;
    }
    Ok(m)
}
