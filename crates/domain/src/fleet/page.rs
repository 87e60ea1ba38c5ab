//! The fleet page's read: every machine with its last check, the verdict of its latest
//! identification, its drift since its baseline with the uncertainty, its sparkline and
//! its active alerts; filtered by site and tag; machines with active alerts first, then
//! in the order asked (`GET /api/v1/fleet` and the dashboard's fleet page).
//!
//! Everything comes from the rows the service maintains ([`crate::fleet::rows`]),
//! filtered, ordered and counted by the database in one read snapshot
//! ([`mtcal_store::Fleet::fleet_page`]: an index walk that stops once the page is full).

use crate::error::DomainError;
use crate::fleet::entry::FleetEntry;
use crate::kinds::IDENTIFICATION;
use crate::trends::DRIFT_DEFINITION;
pub use mtcal_api::fleet::{
    DEFAULT_LIMIT, FleetList, FleetMachine, FleetParams, LastCheck, MAX_LIMIT,
};
use mtcal_store::{FleetCounts, FleetPageQuery, FleetPageRow, FleetSort, Store};
use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// The fleet's counts (how many machines a filter keeps, the filters' choices) as a
/// process keeps them, per scope and filter, for [`FleetCountCache::TTL`]: counting
/// every machine the filter keeps costs more than a page (an index walk that stops
/// after it). A process forgets them when it registers or changes a machine
/// ([`FleetCountCache::forget`]), so its own changes show at once; another process's
/// show within the time they are kept (docs/operations.md, "fleet totals").
#[derive(Debug)]
pub struct FleetCountCache {
    ttl: Duration,
    kept: Mutex<HashMap<CountKey, (Instant, FleetCounts)>>,
    /// Held while the store counts: readers that find their counts expired together
    /// wait for one count and read it, instead of each counting (at 100 000 machines
    /// and 50 readers, 186 counts in 146 s where 30 were due).
    counting: tokio::sync::Mutex<()>,
}

/// What the counts depend on: the asker's sites and tags, the site and tag filters.
type CountKey = (Vec<String>, Vec<String>, Option<String>, Option<String>);

impl FleetCountCache {
    /// How long counts are kept: the most a total lags behind another process's change.
    pub const TTL: Duration = Duration::from_secs(5);
    /// Filters kept at most (past it, the expired ones are dropped, then all).
    const MAX_KEPT: usize = 1024;

    /// Counts kept for `ttl` (zero: counted on every read).
    pub fn new(ttl: Duration) -> Self {
        FleetCountCache {
            ttl,
            kept: Mutex::default(),
            counting: tokio::sync::Mutex::const_new(()),
        }
    }

    /// Forgets every count (a machine registered or changed by this process).
    pub fn forget(&self) {
        self.kept.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    /// The counts of `q`'s scope and filter: kept ones younger than the TTL, else
    /// counted by the store and kept.
    pub async fn counts(
        &self,
        store: &dyn Store,
        q: &FleetPageQuery,
    ) -> Result<FleetCounts, DomainError> {
        let key = (
            q.within_sites.clone(),
            q.within_tags.clone(),
            q.site.clone(),
            q.tag.clone(),
        );
        let fresh = |at: &Instant| at.elapsed() < self.ttl;
        let kept = |key: &CountKey| {
            self.lock()
                .get(key)
                .filter(|(at, _)| fresh(at))
                .map(|(_, c)| c.clone())
        };
        if let Some(c) = kept(&key) {
            return Ok(c);
        }
        // One count at a time: whoever waited reads the count just made.
        let _counting = self.counting.lock().await;
        if let Some(c) = kept(&key) {
            return Ok(c);
        }
        // Counted before the clock is read: kept no longer than the TTL after the count.
        let at = Instant::now();
        let c = store.fleet_counts(q).await?;
        let mut kept = self.lock();
        if kept.len() >= Self::MAX_KEPT {
            kept.retain(|_, (at, _)| fresh(at));
            if kept.len() >= Self::MAX_KEPT {
                kept.clear();
            }
        }
        kept.insert(key, (at, c.clone()));
        Ok(c)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<CountKey, (Instant, FleetCounts)>> {
        self.kept.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Default for FleetCountCache {
    fn default() -> Self {
        Self::new(Self::TTL)
    }
}

/// A filter value, empty meaning none.
fn given(v: &Option<String>) -> Option<String> {
    v.as_ref().filter(|v| !v.is_empty()).cloned()
}

fn order(sort: &str) -> Result<FleetSort, DomainError> {
    match sort {
        "drift" => Ok(FleetSort::DriftUm),
        "drift_urad" => Ok(FleetSort::DriftUrad),
        "name" => Ok(FleetSort::Name),
        "last_check" => Ok(FleetSort::LastCheck),
        other => Err(DomainError::Invalid(format!(
            "sort: drift, drift_urad, name or last_check, got {other:?}"
        ))),
    }
}

/// A machine's entry from its page row; a stored drift that does not decode adds a
/// warning and leaves the drift out.
fn machine(
    r: FleetPageRow,
    profiles: &[mtcal_store::ToleranceProfile],
    warnings: &mut Vec<String>,
) -> FleetMachine {
    let m = r.machine;
    let applies = crate::profiles::applicable(profiles, &m).map(|p| crate::verdicts::ProfileRef {
        id: p.id.clone(),
        scope: p.scope.clone(),
        target: p.target.clone(),
    });
    let entry = r.drift.and_then(|d| match d.entry.decode::<FleetEntry>() {
        Ok(e) => Some(e),
        Err(e) => {
            warnings.push(format!(
                "machine {}: its stored drift does not decode ({e}); listed without it",
                m.id
            ));
            None
        }
    });
    let other = r.other_check;
    let drift_note = match (&entry, &other) {
        (Some(_), _) => None,
        (None, Some(c)) => Some(format!(
            "not applicable: drift is measured between identifications, and this \
             machine's checks are of kind {}",
            c.kind
        )),
        (None, None) => None,
    };
    let (last_check, verdict, summary, baseline, results, drift, sparkline, checks, diagnosis) =
        match entry {
            Some(e) => (
                Some(LastCheck {
                    result_id: e.latest_result_id,
                    kind: IDENTIFICATION.into(),
                    measured_at: e.latest_measured_at,
                }),
                e.verdict,
                e.verdict_summary,
                Some(e.baseline_result_id),
                e.results,
                Some(e.drift),
                e.sparkline,
                (e.misfit, e.explained_model),
                e.diagnosis,
            ),
            None => (other, None, None, None, 0, None, vec![], (None, None), None),
        };
    let (misfit, explained_model) = checks;
    FleetMachine {
        machine_id: m.id,
        name: m.name,
        site: m.site,
        tags: m.tags,
        active_alerts: r.active_alerts.max(0),
        last_check,
        verdict,
        tolerance_profile_id: applies.as_ref().map(|p| p.id.clone()),
        tolerance_profile: applies,
        verdict_summary: summary,
        misfit,
        explained_model,
        diagnosis,
        baseline_result_id: baseline,
        results,
        drift,
        drift_note,
        sparkline,
    }
}

/// One page of the fleet (`GET /api/v1/fleet`; the dashboard's fleet page) as `key`
/// sees it: the machines of its scope only, counted and offered as choices alone (the
/// counts as `counts` keeps them).
pub async fn page(
    store: &dyn Store,
    counts: &FleetCountCache,
    q: &FleetParams,
    key: &mtcal_store::ApiKey,
) -> Result<FleetList, DomainError> {
    let sort = q.sort.clone().unwrap_or_else(|| "drift".into());
    let by = order(&sort)?;
    let limit = crate::paging::limit(q.limit, DEFAULT_LIMIT, MAX_LIMIT)?;
    let offset = crate::paging::offset(q.offset)?;
    let (site, tag) = (given(&q.site), given(&q.tag));
    let query = FleetPageQuery {
        site: site.clone(),
        tag: tag.clone(),
        sort: by,
        offset: i64::try_from(offset).unwrap_or(i64::MAX),
        limit: limit as i64,
        within_sites: key.sites.clone(),
        within_tags: key.tags.clone(),
    };
    let rows = store.fleet_page_rows(&query).await?;
    let found = counts.counts(store, &query).await?;
    let profiles = store.list_tolerances().await?;
    let mut warnings = vec![];
    let machines = rows
        .into_iter()
        .map(|r| machine(r, &profiles, &mut warnings))
        .collect();
    Ok(FleetList {
        definition: DRIFT_DEFINITION.into(),
        site,
        tag,
        sort,
        offset,
        limit,
        total: usize::try_from(found.total).unwrap_or(0),
        sites: found.sites,
        tags: found.tags,
        machines,
        warnings,
    })
}
