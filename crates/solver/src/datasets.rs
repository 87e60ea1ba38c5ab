//! Plain-data forms of the other dataset kinds of the datasets contract: rotary-axis point
//! sets (section 2), positioning runs (section 3) and drift logs (section 4).

use crate::axis::Axis;
use serde::{Deserialize, Serialize};

/// Section 2: measured ball-centre positions at commanded (A, C), instrument frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RotaryPointSet {
    pub machine_id: Option<String>,
    pub measured_at: Option<String>,
    /// Nominal radius of the ball from the C axis, mm, when given.
    pub nominal_radius_mm: Option<f64>,
    pub points: Vec<RotaryPoint>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct RotaryPoint {
    pub a_deg: f64,
    pub c_deg: f64,
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
    pub t_s: Option<f64>,
}

/// Approach direction of a positioning target (ISO 230-2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum Direction {
    Plus,
    Minus,
}

/// Section 3: positioning runs along one or more axes (ISO 230-2 style).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PositioningRuns {
    pub records: Vec<PositioningRecord>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct PositioningRecord {
    pub axis: Axis,
    /// Bidirectional cycle number.
    pub run: i64,
    pub direction: Direction,
    pub target_mm: f64,
    pub deviation_um: f64,
    pub t_s: Option<f64>,
    pub temp_c: Option<f64>,
}

/// What a drift-log channel carries, from its name's suffix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub enum ChannelKind {
    /// `<name>_um`: a displacement (the outputs to explain).
    DisplacementUm,
    /// `<name>_c`: a temperature.
    TemperatureC,
    /// `<name>_rpm`: a spindle speed.
    SpeedRpm,
    /// `<name>_mm`: an axis position.
    PositionMm,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Channel {
    /// Full column name, e.g. `ch5_um`.
    pub name: String,
    pub kind: ChannelKind,
    pub values: Vec<f64>,
}

/// Section 4: a drift log (thermal / time series, ISO 230-3 style).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct DriftLog {
    pub t_s: Vec<f64>,
    pub channels: Vec<Channel>,
}
