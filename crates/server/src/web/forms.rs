//! The dashboard's forms that create things: a machine (fleet page) and a tolerance
//! profile (machine page). Each turns its fields into the API's request and calls the
//! same domain function as the API route (crates/domain: `machines::create`,
//! `profiles::create`), so a form obeys exactly the API's rules; a refused field is an
//! error page naming it, and nothing is stored.

use super::session::{Session, WebState};
use super::{PageResult, WebError};
use crate::error::ApiError;
use axum::extract::{Form, Path, State};
use axum::response::{IntoResponse, Redirect};
use mtcal_domain::machines::NewMachine;
use mtcal_domain::profiles::NewProfile;
use mtcal_views::pages as views;
use serde::Deserialize;
use serde_json::{Map, Value, json};

/// A number field of a form: empty means not given.
fn number(name: &str, v: &Option<String>) -> Result<Option<f64>, WebError> {
    match v.as_deref().map(str::trim).filter(|v| !v.is_empty()) {
        None => Ok(None),
        Some(t) => t.parse::<f64>().map(Some).map_err(|_| {
            WebError(ApiError::InvalidRequest(format!(
                "{name}: {t:?} is not a number"
            )))
        }),
    }
}

/// A text field of a form: trimmed, empty means not given.
fn text(v: &Option<String>) -> Option<String> {
    v.as_deref()
        .map(str::trim)
        .filter(|v| !v.is_empty())
        .map(str::to_string)
}

#[derive(Debug, Deserialize)]
pub struct MachineForm {
    /// Missing reads as empty: refused by the token check (403), like a wrong one.
    #[serde(default)]
    csrf: String,
    #[serde(default)]
    id: String,
    name: Option<String>,
    site: Option<String>,
    /// Comma-separated.
    tags: Option<String>,
    x_min: Option<String>,
    x_max: Option<String>,
    y_min: Option<String>,
    y_max: Option<String>,
    z_min: Option<String>,
    z_max: Option<String>,
}

/// `POST /machines`: registers a machine (the API's `POST /api/v1/machines`), then shows
/// its page.
pub async fn create_machine(
    session: Session,
    client: crate::audit::Client,
    State(s): State<WebState>,
    Form(f): Form<MachineForm>,
) -> PageResult {
    session.check_csrf(&f.csrf)?;
    session.require_write()?;
    let mut travel = std::collections::BTreeMap::new();
    for (axis, lo, hi) in [
        ("X", &f.x_min, &f.x_max),
        ("Y", &f.y_min, &f.y_max),
        ("Z", &f.z_min, &f.z_max),
    ] {
        let name = |end: &str| format!("travel_mm.{axis} {end}");
        match (number(&name("min"), lo)?, number(&name("max"), hi)?) {
            (Some(lo), Some(hi)) => {
                travel.insert(axis.to_string(), [lo, hi]);
            }
            (None, None) => {}
            _ => {
                return Err(WebError(ApiError::InvalidRequest(format!(
                    "travel_mm.{axis}: give both its min and its max, or neither"
                ))));
            }
        }
    }
    let id = f.id.trim().to_string();
    let m = NewMachine {
        name: text(&f.name).unwrap_or_else(|| id.clone()),
        id,
        topology: None,
        travel_mm: travel,
        site: text(&f.site),
        tags: f
            .tags
            .as_deref()
            .unwrap_or("")
            .split(',')
            .map(str::trim)
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect(),
    };
    let m = crate::api::machines::create_machine(&s.app, m, &session.actor(client)).await?;
    Ok(Redirect::to(&format!(
        "{}?notice={}",
        views::machine_href(&m.id),
        views::encode("machine registered")
    ))
    .into_response())
}

#[derive(Debug, Deserialize)]
pub struct ProfileForm {
    #[serde(default)]
    csrf: String,
    /// `machine`, or `tag:<tag>`.
    #[serde(default)]
    target: String,
    positioning_um: Option<String>,
    straightness_um: Option<String>,
    angular_urad: Option<String>,
    per_length_mm: Option<String>,
    squareness_urad: Option<String>,
    drift_um: Option<String>,
    drift_urad: Option<String>,
}

/// The terms each range field of the profile form limits (ISO 230-1 names).
const POSITIONING: [&str; 3] = ["EXX", "EYY", "EZZ"];
const STRAIGHTNESS: [&str; 6] = ["EYX", "EZX", "EXY", "EZY", "EXZ", "EYZ"];
const ANGULAR: [&str; 9] = [
    "EAX", "EBX", "ECX", "EAY", "EBY", "ECY", "EAZ", "EBZ", "ECZ",
];
const SQUARENESS: [&str; 3] = ["EC0Y", "EB0Z", "EA0Z"];

/// The profile request of the form's fields (the API's `POST /api/v1/tolerances`).
fn profile_request(machine: &str, f: &ProfileForm) -> Result<NewProfile, WebError> {
    let (scope, target) = match f.target.strip_prefix("tag:") {
        Some(tag) => ("tag", tag.to_string()),
        None => ("machine", machine.to_string()),
    };
    let per_length = number("per_length_mm", &f.per_length_mm)?;
    let range = |v: f64| match per_length {
        Some(l) => json!({"range": v, "per_length_mm": l}),
        None => json!(v),
    };
    let mut terms = Map::new();
    for (field, v, names) in [
        ("positioning_um", &f.positioning_um, &POSITIONING[..]),
        ("straightness_um", &f.straightness_um, &STRAIGHTNESS[..]),
        ("angular_urad", &f.angular_urad, &ANGULAR[..]),
    ] {
        if let Some(v) = number(field, v)? {
            for n in names {
                terms.insert(n.to_string(), range(v));
            }
        }
    }
    let mut limits = Map::new();
    if !terms.is_empty() {
        limits.insert("terms".into(), Value::Object(terms));
    }
    if let Some(v) = number("squareness_urad", &f.squareness_urad)? {
        let sq: Map<String, Value> = SQUARENESS
            .iter()
            .map(|n| (n.to_string(), json!(v)))
            .collect();
        limits.insert("squareness".into(), Value::Object(sq));
    }
    for (name, v) in [("drift_um", &f.drift_um), ("drift_urad", &f.drift_urad)] {
        if let Some(v) = number(name, v)? {
            limits.insert(name.into(), json!(v));
        }
    }
    let limits = serde_json::from_value(Value::Object(limits))
        .map_err(|e| WebError(ApiError::InvalidRequest(format!("limits: {e}"))))?;
    Ok(NewProfile {
        scope: scope.into(),
        target,
        limits,
        webhook_url: None,
        webhook_secret: None,
    })
}

/// `POST /machines/{id}/tolerance`: creates a tolerance profile of the machine or of one
/// of its tags (the API's `POST /api/v1/tolerances`; a webhook is set through the API),
/// refreshes the verdicts of the machines it applies to, and shows the machine's page.
pub async fn create_profile(
    session: Session,
    client: crate::audit::Client,
    State(s): State<WebState>,
    Path(id): Path<String>,
    Form(f): Form<ProfileForm>,
) -> PageResult {
    session.check_csrf(&f.csrf)?;
    session.require_write()?;
    s.app.store.get_machine(&id).await?;
    let p = profile_request(&id, &f)?;
    let created =
        crate::api::tolerances::create_profile(&s.app, &p, &session.actor(client)).await?;
    Ok(Redirect::to(&format!(
        "{}?notice={}",
        views::machine_href(&id),
        views::encode(&format!(
            "tolerance profile created for {} {}",
            created.scope, created.target
        ))
    ))
    .into_response())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn form(target: &str) -> ProfileForm {
        ProfileForm {
            csrf: String::new(),
            target: target.into(),
            positioning_um: Some("10".into()),
            straightness_um: Some(" ".into()),
            angular_urad: None,
            per_length_mm: Some("300".into()),
            squareness_urad: Some("30".into()),
            drift_um: None,
            drift_urad: Some("5".into()),
        }
    }

    #[test]
    fn the_profile_form_makes_the_apis_request() {
        let p = profile_request("VMC-1", &form("machine")).unwrap();
        assert_eq!((p.scope.as_str(), p.target.as_str()), ("machine", "VMC-1"));
        let limits = serde_json::to_value(&p.limits).unwrap();
        assert_eq!(limits["terms"]["EYY"]["range"], 10.0);
        assert_eq!(limits["terms"]["EYY"]["per_length_mm"], 300.0);
        assert!(
            limits["terms"].get("EYX").is_none(),
            "an empty field limits nothing"
        );
        assert_eq!(limits["squareness"]["EA0Z"], 30.0);
        assert_eq!(limits["drift_urad"], 5.0);
        let p = profile_request("VMC-1", &form("tag:vmc")).unwrap();
        assert_eq!((p.scope.as_str(), p.target.as_str()), ("tag", "vmc"));
        let mut bad = form("machine");
        bad.squareness_urad = Some("thirty".into());
        let e = profile_request("VMC-1", &bad).expect_err("refused");
        assert!(format!("{:?}", e.0).contains("squareness_urad"));
    }
}
