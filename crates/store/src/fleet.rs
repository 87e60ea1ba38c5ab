//! The fleet's drift, maintained by the service, and the fleet page: [`Fleet`].

use crate::StoreFuture;
use crate::machines::Machine;
pub use mtcal_api::fleet::LastCheck;
use serde::Serialize;

/// The fleet's drift (one row per machine, maintained by the service) and the fleet
/// page. Implementations must make each method atomic.
pub trait Fleet: Send + Sync {
    /// Stores a machine's drift unless the stored row was computed from a later read
    /// (`read_at_ms`); returns whether it was stored.
    fn put_fleet_drift<'a>(&'a self, row: &'a FleetDriftRow) -> StoreFuture<'a, bool>;

    /// Stores many machines' rows in one transaction, each as [`Fleet::put_fleet_drift`];
    /// returns how many were stored.
    fn put_fleet_drifts<'a>(&'a self, rows: &'a [FleetDriftRow]) -> StoreFuture<'a, usize>;

    /// The machine and basis ([`FleetDriftRow::basis`]) of every stored row whose
    /// machine id is after `after` and up to `through` (None: no bound), by machine id.
    fn fleet_drift_bases<'a>(
        &'a self,
        after: Option<&'a str>,
        through: Option<&'a str>,
    ) -> StoreFuture<'a, Vec<(String, Option<String>)>>;

    /// Removes a machine's drift (it had no result of the kind when read at
    /// `read_at_ms`) unless the stored row was computed from a read as late or later (a
    /// result landed meanwhile: on a tie the row is kept, the refresh at start settles
    /// it); returns whether it was removed.
    fn delete_fleet_drift<'a>(
        &'a self,
        machine_id: &'a str,
        read_at_ms: i64,
    ) -> StoreFuture<'a, bool>;

    /// The machines' drift, largest first by `drift_um` (`by_um`) or `drift_urad`, at
    /// most `limit`, with each machine's current name and site.
    fn fleet_drift_ranked(
        &self,
        by_um: bool,
        limit: usize,
    ) -> StoreFuture<'_, Vec<(FleetDriftRow, String, Option<String>)>>;

    /// One page of the fleet ([`FleetPageQuery`]): machines with their drift rows and
    /// active alert counts, filtered, sorted and counted by the database.
    fn fleet_page<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetPage>;

    /// [`Fleet::fleet_page`]'s rows alone, without counting the machines the filter
    /// keeps (for an asker that keeps the counts: [`Fleet::fleet_counts`]).
    fn fleet_page_rows<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, Vec<FleetPageRow>>;

    /// [`Fleet::fleet_page`]'s counts alone: how many machines the query's filter and
    /// scope keep, and the filters' choices (its order and page are not read).
    fn fleet_counts<'a>(&'a self, q: &'a FleetPageQuery) -> StoreFuture<'a, FleetCounts>;
}

/// A machine's drift since its baseline as the fleet ranking stores it (computed by the
/// service when a result lands or the baseline changes).
#[derive(Debug, Clone, PartialEq)]
pub struct FleetDriftRow {
    pub machine_id: String,
    /// When the results it was computed from were read (ms since the epoch): a row from
    /// an older read never replaces a newer one.
    pub read_at_ms: i64,
    pub drift_um: f64,
    pub drift_urad: f64,
    /// The ranking's entry for the machine (ids, result count, drift, uncertainty).
    pub entry: EntryJson,
    /// When the latest result was measured (the fleet page sorts by it).
    pub latest_measured_at: Option<String>,
    /// What the row was computed from, as the service names it (None: written by an
    /// older version); a refresh skips the rows whose basis is still current.
    pub basis: Option<String>,
}

/// A fleet row's entry as JSON text, kept as stored: its reader decodes it straight into
/// its own type ([`EntryJson::decode`]), with no `serde_json::Value` in between (the
/// fleet page reads 100 of them a request).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EntryJson(String);

impl EntryJson {
    /// The entry of `value`, written as JSON.
    pub fn new<T: Serialize>(value: &T) -> serde_json::Result<Self> {
        serde_json::to_string(value).map(EntryJson)
    }

    /// An entry as a store holds it (not checked here: [`EntryJson::decode`] says when
    /// it is not JSON of the type asked for).
    pub(crate) fn stored(text: String) -> Self {
        EntryJson(text)
    }

    /// The entry decoded as a `T`.
    pub fn decode<T: serde::de::DeserializeOwned>(&self) -> serde_json::Result<T> {
        serde_json::from_str(&self.0)
    }

    /// The JSON text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// The orders of the fleet page.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FleetSort {
    /// Largest drift in µm first.
    DriftUm,
    /// Largest drift in µrad first.
    DriftUrad,
    /// By machine id.
    Name,
    /// Most recent check first.
    LastCheck,
}

/// One page of the fleet: machines filtered by site and tag, those with active alerts
/// first, then in `sort` order.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPageQuery {
    pub site: Option<String>,
    pub tag: Option<String>,
    pub sort: FleetSort,
    pub offset: i64,
    pub limit: i64,
    /// The asker's scope (a key's sites and tags, empty: no limit): machines outside it
    /// are not shown, counted or offered as a filter's choice.
    pub within_sites: Vec<String>,
    pub within_tags: Vec<String>,
}

/// A machine on the fleet page: its drift row (None before its first identification)
/// and how many active alerts it has.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPageRow {
    pub machine: Machine,
    pub drift: Option<FleetDriftRow>,
    pub active_alerts: i64,
    /// For a machine without a drift row (no identification): its latest result of any
    /// other kind that is not excluded (None: it has no result, or it has a drift row,
    /// whose entry names its latest identification).
    pub other_check: Option<LastCheck>,
}

/// How many machines a fleet filter keeps in all, and the filters' choices.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FleetCounts {
    pub total: i64,
    /// Every site and every tag of the fleet (of the asker's scope), sorted.
    pub sites: Vec<String>,
    pub tags: Vec<String>,
}

/// A fleet page and how many machines match the filter in all.
#[derive(Debug, Clone, PartialEq)]
pub struct FleetPage {
    pub rows: Vec<FleetPageRow>,
    pub total: i64,
    /// Every site and every tag of the fleet, sorted (the filters' choices).
    pub sites: Vec<String>,
    pub tags: Vec<String>,
}
