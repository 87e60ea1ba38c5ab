//! A tolerance profile's content: the limits of the error functions (a range, or per
//! length by ISO 230-1's rule of proportionality), of the squarenesses and of the
//! figures of ISO 230-2 and ISO 230-4, and the items' names as the standards give them.

use crate::terms::{SquarenessTerm, Term};
use crate::uncertainty::g;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A limit on an error function: the range (max − min) of its values over the measured
/// travel (ISO 230-1), µm or µrad. In a profile, a bare number (`"EXX": 4`) is a range
/// limit over the whole measured travel; an object states it per length
/// (`{"range": 10, "per_length_mm": 300, "min": 1}`: 10 µm per 300 mm).
///
/// **Per length** (ISO 230-1's rule of proportionality): the limit for a measured length
/// L is t(L) = range × L / per_length_mm, for L shorter or longer than the reference
/// length, but not less than `min` (default [`MIN_PROPORTIONAL_UM`] µm, or µrad): a
/// proportional tolerance is not reduced below a minimum, as ISO 230-1 lets a test code
/// state one.
///
/// *Reading:* a stored profile of an earlier version held a bare number meaning max
/// |f(q)| over the travel. It is **interpreted**, not migrated: read as a range limit.
/// Since f(0) = 0 lies in the range whenever the travel includes 0, the range is at least
/// max |f|, so the reading is never more lenient (docs/api.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TermLimit {
    pub range: f64,
    pub per_length_mm: Option<f64>,
    pub min: Option<f64>,
}

/// The floor of a proportional limit when the profile states none (µm or µrad).
pub const MIN_PROPORTIONAL_UM: f64 = 1.0;

impl TermLimit {
    /// A range limit over the whole measured travel.
    pub fn range(range: f64) -> TermLimit {
        TermLimit {
            range,
            per_length_mm: None,
            min: None,
        }
    }

    /// The limit for a measured length `l_mm` (None: unknown length) and how it was
    /// worked out (None for a plain range limit).
    pub fn at_length(&self, l_mm: Option<f64>) -> (f64, Option<String>) {
        let Some(per) = self.per_length_mm else {
            return (self.range, None);
        };
        let floor = self.min.unwrap_or(MIN_PROPORTIONAL_UM);
        let Some(l) = l_mm else {
            return (
                self.range,
                Some(format!(
                    "{} per {} mm, the measured length unknown: taken as stated",
                    g(self.range),
                    g(per)
                )),
            );
        };
        let t = self.range * l / per;
        if t < floor {
            (
                floor,
                Some(format!(
                    "{} per {} mm over L = {} mm gives {}, below the minimum {}: {}",
                    g(self.range),
                    g(per),
                    g(l),
                    g(t),
                    g(floor),
                    g(floor)
                )),
            )
        } else {
            (
                t,
                Some(format!(
                    "{} per {} mm over L = {} mm: {} × {}/{} = {}",
                    g(self.range),
                    g(per),
                    g(l),
                    g(self.range),
                    g(l),
                    g(per),
                    g(t)
                )),
            )
        }
    }

    fn validate(&self, at: &str) -> Result<(), String> {
        let pos = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "{at}{what}: a limit must be a positive finite number, got {v}"
                ))
            }
        };
        pos("", self.range)?;
        if let Some(l) = self.per_length_mm {
            pos(".per_length_mm", l)?;
        }
        if let Some(m) = self.min {
            pos(".min", m)?;
        }
        if self.min.is_some() && self.per_length_mm.is_none() {
            return Err(format!(
                "{at}.min: a minimum applies to a per-length limit only (give per_length_mm)"
            ));
        }
        Ok(())
    }
}

impl Serialize for TermLimit {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.per_length_mm.is_none() && self.min.is_none() {
            return s.serialize_f64(self.range);
        }
        #[derive(Serialize)]
        struct Spec {
            range: f64,
            #[serde(skip_serializing_if = "Option::is_none")]
            per_length_mm: Option<f64>,
            #[serde(skip_serializing_if = "Option::is_none")]
            min: Option<f64>,
        }
        Spec {
            range: self.range,
            per_length_mm: self.per_length_mm,
            min: self.min,
        }
        .serialize(s)
    }
}

impl<'de> Deserialize<'de> for TermLimit {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let v = serde_json::Value::deserialize(d)?;
        let num = |v: &serde_json::Value, what: &str| {
            v.as_f64()
                .ok_or_else(|| D::Error::custom(format!("{what}: a number, got {v}")))
        };
        match &v {
            serde_json::Value::Number(_) => Ok(TermLimit::range(num(&v, "a limit")?)),
            serde_json::Value::Object(o) => {
                for k in o.keys() {
                    if !["range", "per_length_mm", "min"].contains(&k.as_str()) {
                        return Err(D::Error::custom(format!(
                            "unknown field `{k}` of a limit (range, per_length_mm, min)"
                        )));
                    }
                }
                let range = o
                    .get("range")
                    .ok_or_else(|| D::Error::custom("a limit object needs `range`"))?;
                Ok(TermLimit {
                    range: num(range, "range")?,
                    per_length_mm: o
                        .get("per_length_mm")
                        .map(|v| num(v, "per_length_mm"))
                        .transpose()?,
                    min: o.get("min").map(|v| num(v, "min")).transpose()?,
                })
            }
            other => Err(D::Error::custom(format!(
                "a limit is a number (the range) or {{\"range\", \"per_length_mm\", \"min\"}}, got {other}"
            ))),
        }
    }
}

/// The OpenAPI shape of a [`TermLimit`] (a number, or an object).
#[cfg(feature = "openapi")]
#[derive(utoipa::ToSchema)]
#[allow(dead_code)]
#[serde(untagged)]
pub enum TermLimitSchema {
    /// The range limit over the whole measured travel.
    Range(f64),
    /// A limit per length: range × L / per_length_mm, not less than `min`.
    PerLength {
        range: f64,
        per_length_mm: f64,
        min: Option<f64>,
    },
}

/// A tolerance profile's limits. Every limit is positive; units are those of the item
/// (µm or µrad; a figure of a standard carries its unit in its name).
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// Per error function (`EXX`, …): the range (max − min) over the measured travel,
    /// µm or µrad, as a number, or per length as `{"range", "per_length_mm", "min"}`.
    #[serde(default)]
    #[cfg_attr(feature = "openapi", schema(value_type = BTreeMap<String, TermLimitSchema>))]
    pub terms: BTreeMap<String, TermLimit>,
    /// Per squareness (`EC0Y`, `EB0Z`, `EA0Z`): |value|, µrad.
    #[serde(default)]
    pub squareness: BTreeMap<String, f64>,
    /// Per figure of a standard (`iso230_2.X.E_um`, `iso230_4.XY.bi.G_um`, …): |value|.
    #[serde(default)]
    pub standards: BTreeMap<String, f64>,
    /// Drift threshold on translational terms, µm: an alert is raised when a term's
    /// change since the baseline exceeds it by more than the expanded uncertainty.
    #[serde(default)]
    pub drift_um: Option<f64>,
    /// Drift threshold on angular terms and squareness, µrad.
    #[serde(default)]
    pub drift_urad: Option<f64>,
}

impl Limits {
    /// Checks names and values; the message names the offending entry.
    pub fn validate(&self) -> Result<(), String> {
        let check = |what: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!(
                    "{what}: a limit must be a positive finite number, got {v}"
                ))
            }
        };
        for (name, l) in &self.terms {
            if Term::parse(name).is_none() {
                return Err(format!(
                    "terms.{name}: not one of the 18 ISO 230-1 error functions (EXX … ECZ)"
                ));
            }
            l.validate(&format!("terms.{name}"))?;
        }
        for (name, &v) in &self.squareness {
            if SquarenessTerm::parse(name).is_none() {
                return Err(format!("squareness.{name}: one of EC0Y, EB0Z, EA0Z"));
            }
            check(&format!("squareness.{name}"), v)?;
        }
        for (name, &v) in &self.standards {
            if !is_standard_figure(name) {
                return Err(format!(
                    "standards.{name}: a figure is named iso230_2.<X|Y|Z>.<figure>_um|_urad or \
                     iso230_4.<XY|XZ|YZ>.<ccw|cw|bi>.<figure>_um"
                ));
            }
            check(&format!("standards.{name}"), v)?;
        }
        if let Some(v) = self.drift_um {
            check("drift_um", v)?;
        }
        if let Some(v) = self.drift_urad {
            check("drift_urad", v)?;
        }
        Ok(())
    }

    /// Number of limits (drift thresholds included).
    pub fn len(&self) -> usize {
        self.terms.len()
            + self.squareness.len()
            + self.standards.len()
            + self.drift_um.is_some() as usize
            + self.drift_urad.is_some() as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The drift threshold for an item of `unit` (`um` or `urad`).
    pub fn drift_threshold(&self, unit: &str) -> Option<f64> {
        if unit == "urad" {
            self.drift_urad
        } else {
            self.drift_um
        }
    }
}

/// Whether `name` has the shape of a figure of a standard: `iso230_2.<axis>.<figure>` or
/// `iso230_4.<plane>.<direction>.<figure>`, the figure ending in `_um` or `_urad`.
pub fn is_standard_figure(name: &str) -> bool {
    let parts: Vec<&str> = name.split('.').collect();
    let figure_ok = |f: &str| {
        (f.ends_with("_um") || f.ends_with("_urad"))
            && f.len() > 3
            && f.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    match parts.as_slice() {
        ["iso230_2", axis, figure] => matches!(*axis, "X" | "Y" | "Z") && figure_ok(figure),
        ["iso230_4", plane, dir, figure] => {
            matches!(*plane, "XY" | "XZ" | "YZ")
                && matches!(*dir, "ccw" | "cw" | "bi")
                && figure_ok(figure)
        }
        _ => false,
    }
}

/// An item's name as a person reads it: the error function's or squareness's ISO 230-1
/// name, a figure of a standard with its standard's symbol and name (`ISO 230-2 X: E,
/// bidirectional systematic positional deviation`), never a raw key.
pub fn display_name(item: &str) -> String {
    let parts: Vec<&str> = item.split('.').collect();
    match parts.as_slice() {
        ["iso230_2", axis, figure] => match crate::standards::iso230_2::figure_name(figure) {
            Some((symbol, name)) => format!("ISO 230-2 {axis}: {symbol}, {name}"),
            None => format!("ISO 230-2 {axis}: {figure}"),
        },
        ["iso230_4", plane, dir, figure] => {
            let dir = match *dir {
                "bi" => "bidirectional",
                "ccw" => "ccw",
                "cw" => "cw",
                other => other,
            };
            match crate::standards::iso230_4::figure_name(figure) {
                Some((symbol, name)) => format!("ISO 230-4 {plane} {dir}: {symbol}, {name}"),
                None => format!("ISO 230-4 {plane} {dir}: {figure}"),
            }
        }
        _ => item.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_are_validated_with_the_entry_named() {
        let mut l = Limits::default();
        l.terms.insert("EQX".into(), TermLimit::range(1.0));
        assert!(l.validate().unwrap_err().contains("terms.EQX"));
        let mut l = Limits::default();
        l.terms.insert("EXX".into(), TermLimit::range(0.0));
        assert!(l.validate().unwrap_err().contains("positive"));
        let mut l = Limits::default();
        l.terms.insert(
            "EXX".into(),
            TermLimit {
                range: 1.0,
                per_length_mm: Some(-3.0),
                min: None,
            },
        );
        assert!(
            l.validate()
                .unwrap_err()
                .contains("terms.EXX.per_length_mm")
        );
        let mut l = Limits::default();
        l.terms.insert(
            "EXX".into(),
            TermLimit {
                range: 1.0,
                per_length_mm: None,
                min: Some(1.0),
            },
        );
        assert!(l.validate().unwrap_err().contains("terms.EXX.min"));
        let mut l = Limits::default();
        l.squareness.insert("EC0Y".into(), f64::INFINITY);
        assert!(l.validate().is_err());
        let mut l = Limits::default();
        l.standards.insert("iso230_2.W.E_um".into(), 1.0);
        assert!(
            l.validate()
                .unwrap_err()
                .contains("standards.iso230_2.W.E_um")
        );
        let l = Limits {
            drift_um: Some(-1.0),
            ..Limits::default()
        };
        assert!(l.validate().unwrap_err().contains("drift_um"));
        for ok in [
            "iso230_2.X.E_um",
            "iso230_2.Z.R_up_um",
            "iso230_4.XY.ccw.G_um",
            "iso230_4.YZ.bi.H_um",
        ] {
            assert!(is_standard_figure(ok), "{ok}");
        }
        for bad in ["iso230_2.X.E", "iso230_4.XY.up.G_um", "iso230_2.X", "EXX"] {
            assert!(!is_standard_figure(bad), "{bad}");
        }
        serde_json::from_str::<Limits>(r#"{"termz": {}}"#).unwrap_err();
    }

    #[test]
    fn items_are_named_as_the_standards_name_them() {
        assert_eq!(
            display_name("iso230_2.X.E_um"),
            "ISO 230-2 X: E, bidirectional systematic positional deviation"
        );
        assert_eq!(
            display_name("iso230_4.XY.bi.H_um"),
            "ISO 230-4 XY bidirectional: H, circular hysteresis"
        );
        assert_eq!(display_name("EXX"), "EXX");
    }
}
