//! The machines: [`Machines`].

use crate::StoreFuture;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

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

/// A registered machine tool.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Machine {
    pub id: String,
    pub name: String,
    /// `{"workpiece": ["X", "Y"], "tool": ["Z"]}` (kinematics contract).
    #[cfg_attr(feature = "openapi", schema(value_type = Object))]
    pub topology: Value,
    /// Travel range per axis, mm: `{"X": [-250, 250], ...}`.
    pub travel_mm: BTreeMap<String, [f64; 2]>,
    pub site: Option<String>,
    pub tags: Vec<String>,
    /// Result that drift is measured from; `None` means the machine's first result.
    pub baseline_result_id: Option<String>,
    pub created_at: String,
    pub updated_at: String,
}

/// Fields of a machine that an update may change (`None`: keep).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct MachinePatch {
    /// Not blank, at most 200 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::name_or_null))]
    pub name: Option<String>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::topology))]
    pub topology: Option<Value>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::travel_or_null))]
    pub travel_mm: Option<BTreeMap<String, [f64; 2]>>,
    /// Not blank, at most 100 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::site_or_null))]
    pub site: Option<String>,
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::tags_or_null))]
    pub tags: Option<Vec<String>>,
    pub baseline_result_id: Option<String>,
}
