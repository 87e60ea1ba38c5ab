//! Machines: a machine as stored, the fields an update may change, and a machine to
//! register.

use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;

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

/// A machine to register.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct NewMachine {
    /// 1–64 characters: letters, digits, '.', '_', '-' (not `.` or `..`).
    #[cfg_attr(
        feature = "openapi",
        schema(pattern = "^(?!\\.{1,2}$)[A-Za-z0-9._-]{1,64}$")
    )]
    pub id: String,
    /// Not blank, at most 200 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::name))]
    pub name: String,
    /// Axes on the workpiece and tool sides (default `{"workpiece": ["X", "Y"], "tool": ["Z"]}`).
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::topology))]
    pub topology: Option<serde_json::Value>,
    /// Travel per axis, mm, e.g. `{"X": [-250, 250]}`.
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::travel))]
    pub travel_mm: BTreeMap<String, [f64; 2]>,
    /// Not blank, at most 100 characters, no control character.
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::site_or_null))]
    pub site: Option<String>,
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(schema_with = crate::schemas::tags))]
    pub tags: Vec<String>,
}
