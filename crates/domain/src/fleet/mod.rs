//! The fleet: one row per machine with an identification, maintained as results land
//! ([`rows`]: drift since the baseline, the latest verdict, the sparkline, and the refresh
//! of the whole fleet at start), the entry each row holds ([`entry`]), and the two reads
//! of the rows: ranked by drift ([`entry::ranked`]) and the fleet page ([`page`]).

pub mod entry;
pub mod page;
pub mod rows;

pub use entry::{FleetDrift, FleetEntry, FleetQuery, VerdictSummary};
pub use page::{FleetList, FleetMachine, FleetParams, LastCheck};
pub use rows::{
    ROW_FORMAT, Refreshed, basis, refresh_all, refresh_machine, refresh_profile_targets, sparkline,
};
