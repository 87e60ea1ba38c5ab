//! The fleet's drift, maintained by the service, and the fleet page: [`Fleet`].

use crate::StoreFuture;
use crate::model::{FleetDriftRow, FleetPage, FleetPageQuery};

/// The fleet's drift (one row per machine, maintained by the service) and the fleet
/// page. Implementations must make each method atomic.
pub trait Fleet: Send + Sync {
    /// Stores a machine's drift unless the stored row was computed from a later read
    /// (`read_at_ms`); returns whether it was stored.
    fn put_fleet_drift<'a>(&'a self, row: &'a FleetDriftRow) -> StoreFuture<'a, bool>;

    /// Stores many machines' rows in one transaction, each as [`Fleet::put_fleet_drift`];
    /// returns how many were stored.
    fn put_fleet_drifts<'a>(&'a self, rows: &'a [FleetDriftRow]) -> StoreFuture<'a, usize>;

    /// Every stored row's machine and basis ([`FleetDriftRow::basis`]).
    fn fleet_drift_bases(&self) -> StoreFuture<'_, Vec<(String, Option<String>)>>;

    /// Removes a machine's drift (it has no result of the kind any more).
    fn delete_fleet_drift<'a>(&'a self, machine_id: &'a str) -> StoreFuture<'a, ()>;

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
}
