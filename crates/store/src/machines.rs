//! The machines: [`Machines`].

use crate::StoreFuture;
pub use mtcal_api::machines::{Machine, MachinePatch};

/// The machines the service calibrates. Implementations must make each method atomic.
pub trait Machines: Send + Sync {
    fn create_machine<'a>(&'a self, m: &'a Machine) -> StoreFuture<'a, Machine>;

    fn get_machine<'a>(&'a self, id: &'a str) -> StoreFuture<'a, Machine>;

    /// Applies a patch (the rules module's `apply_patch`: a baseline must be one of the machine's
    /// results).
    fn update_machine<'a>(&'a self, id: &'a str, p: &'a MachinePatch) -> StoreFuture<'a, Machine>;

    /// Machines ordered by id, after `after` (keyset pagination).
    fn list_machines<'a>(
        &'a self,
        after: Option<&'a str>,
        limit: i64,
    ) -> StoreFuture<'a, Vec<Machine>>;
}
