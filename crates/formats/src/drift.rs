//! Drift logs (datasets contract, section 4; `docs/datasets.md`), ISO 230-3 style thermal
//! or time series.
//!
//! CSV: `t_s` required (strictly increasing over the file), then any number of channels
//! named by their unit suffix: `<name>_um` displacements, `<name>_c` temperatures,
//! `<name>_rpm` spindle speeds, `<name>_mm` positions (`<name>` non-empty); at least one
//! channel and one row. Other columns are rejected unless `x-` prefixed.

use crate::csv_core::{CsvTable, check_increasing};
use crate::csv_out::CsvOut;
use crate::limits::Quantity;
use crate::{FormatError, Limits, invalid_input};
use mtcal_solver::datasets::{Channel, ChannelKind, DriftLog};
use std::io::Write;
use std::path::Path;

/// The kind of a drift-log channel from its name's unit suffix, `None` when the name has
/// no recognised suffix or nothing before it.
pub fn channel_kind(name: &str) -> Option<ChannelKind> {
    [
        ("_um", ChannelKind::DisplacementUm),
        ("_c", ChannelKind::TemperatureC),
        ("_rpm", ChannelKind::SpeedRpm),
        ("_mm", ChannelKind::PositionMm),
    ]
    .into_iter()
    .find_map(|(suffix, kind)| {
        name.strip_suffix(suffix)
            .filter(|stem| !stem.is_empty())
            .map(|_| kind)
    })
}

fn suffix(kind: ChannelKind) -> &'static str {
    match kind {
        ChannelKind::DisplacementUm => "_um",
        ChannelKind::TemperatureC => "_c",
        ChannelKind::SpeedRpm => "_rpm",
        ChannelKind::PositionMm => "_mm",
    }
}

/// Reads a drift log from `bytes` (CSV, possibly gzip) named `name`.
pub fn read_drift_log(name: &str, bytes: &[u8], limits: &Limits) -> Result<DriftLog, FormatError> {
    let data = crate::decode_single(name, bytes, limits)?;
    let mut t = CsvTable::open(name, &data, limits)?;
    t.check_columns(
        &["t_s"],
        |c| c == "t_s" || channel_kind(c).is_some(),
        "t_s and channels named <name>_um, <name>_c, <name>_rpm or <name>_mm",
    )?;
    let c_t = t.col("t_s").unwrap_or_default();
    let hint = t.remaining_rows_hint();
    let mut channels: Vec<(usize, Channel)> = t
        .header()
        .iter()
        .enumerate()
        .filter(|(_, n)| n.as_str() != "t_s")
        .filter_map(|(i, n)| {
            channel_kind(n).map(|kind| {
                let values = Vec::with_capacity(hint);
                (
                    i,
                    Channel {
                        name: n.clone(),
                        kind,
                        values,
                    },
                )
            })
        })
        .collect();
    if channels.is_empty() {
        return Err(t.header_error("", "a drift log needs at least one channel besides t_s"));
    }
    let numbers = std::iter::once((c_t, Quantity::Time))
        .chain(channels.iter().map(|(i, _)| (*i, Quantity::Value)));
    t.scan(&numbers.collect::<Vec<_>>());
    let mut t_s: Vec<f64> = Vec::with_capacity(hint);
    while t.next_row()? {
        let v = t.quantity(c_t, Quantity::Time)?;
        check_increasing(&t, c_t, t_s.last().copied(), v, "the file")?;
        t_s.push(v);
        for (i, ch) in channels.iter_mut() {
            ch.values.push(t.quantity(*i, Quantity::Value)?);
        }
    }
    if t_s.is_empty() {
        return Err(t.header_error("", "the file has no rows after the header"));
    }
    t_s.shrink_to_fit();
    for (_, ch) in channels.iter_mut() {
        ch.values.shrink_to_fit();
        if ch.kind == ChannelKind::DisplacementUm {
            crate::units::check_micrometres(name, &ch.name, [ch.values.as_slice()])?;
        }
    }
    Ok(DriftLog {
        t_s,
        channels: channels.into_iter().map(|(_, c)| c).collect(),
    })
}

/// Reads a drift log from a file (gzip accepted).
pub fn read_drift_log_path(path: &Path, limits: &Limits) -> Result<DriftLog, FormatError> {
    let (name, data) = crate::read_single(path, limits)?;
    read_drift_log(&name, &data, limits)
}

/// Writes a drift log: `t_s` then the channels in order.
pub fn write_drift_log(w: impl Write, log: &DriftLog) -> std::io::Result<()> {
    let n = log.t_s.len();
    for ch in &log.channels {
        if channel_kind(&ch.name) != Some(ch.kind) || !ch.name.ends_with(suffix(ch.kind)) {
            return Err(invalid_input(format!(
                "channel `{}` must be named <name>{}",
                ch.name,
                suffix(ch.kind)
            )));
        }
        if ch.values.len() != n {
            return Err(invalid_input(format!(
                "channel `{}` has {} values for {n} times",
                ch.name,
                ch.values.len()
            )));
        }
    }
    let all = log
        .t_s
        .iter()
        .chain(log.channels.iter().flat_map(|c| &c.values));
    if all.into_iter().any(|v| !v.is_finite()) {
        return Err(invalid_input("non-finite value in the drift log"));
    }
    if log.t_s.windows(2).any(|p| p[1] <= p[0]) {
        return Err(invalid_input("t_s is not strictly increasing"));
    }
    let names = std::iter::once("t_s").chain(log.channels.iter().map(|c| c.name.as_str()));
    let mut out = CsvOut::with_header(w, names)?;
    for i in 0..n {
        out.number(log.t_s[i])?;
        out.numbers(log.channels.iter().map(|c| c.values[i]))?;
        out.end_record()?;
    }
    out.finish()
}
/// Writes the drift-log models' predictions at full resolution (`docs/diagnosis-series.md`,
/// "Prediction export"): `t_s,part` then, per displacement channel `<ch>_um`, the columns
/// `<ch>_measured_um`, `<ch>_model_um` and `<ch>_compensation_um`. `part` is `fit` for
/// the samples the model was fitted on and `held_out` for the rest. The compensation is
/// −(model − model at the first sample): the correction to add along the channel's
/// direction to cancel the predicted thermal drift since the start of the log.
pub fn write_drift_predictions(
    w: impl Write,
    p: &mtcal_solver::diagnosis::series::drift::DriftPredictions,
) -> std::io::Result<()> {
    let n = p.t_s.len();
    if p.channels
        .iter()
        .any(|c| c.measured_um.len() != n || c.model_um.len() != n)
    {
        return Err(invalid_input("prediction series of unequal lengths"));
    }
    let names: Vec<String> = ["t_s".to_string(), "part".to_string()]
        .into_iter()
        .chain(p.channels.iter().flat_map(|c| {
            let stem = c.name.strip_suffix("_um").unwrap_or(&c.name);
            ["measured", "model", "compensation"].map(|col| format!("{stem}_{col}_um"))
        }))
        .collect();
    let mut out = CsvOut::with_header(w, names.iter().map(String::as_str))?;
    for i in 0..n {
        out.number(p.t_s[i])?;
        out.text(if i < p.n_fit { "fit" } else { "held_out" })?;
        for c in &p.channels {
            out.numbers([
                c.measured_um[i],
                c.model_um[i],
                c.model_at_start_um - c.model_um[i],
            ])?;
        }
        out.end_record()?;
    }
    out.finish()
}
