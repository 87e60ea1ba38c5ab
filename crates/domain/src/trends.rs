//! Trends over a machine's history, and the service's side of result arithmetic: the
//! stored scalars of a result ([`ResultScalars`]) seen as a check of
//! [`mtcal_solver::comparison`], which evaluates terms (in the reporting convention,
//! with their standard uncertainty), differences and drift, only inside the travel a
//! check measured. This module adapts the stored row, words the travel for messages and
//! builds the term and summary trends (`GET …/trends/term`, `…/trends/summary`, the
//! machine page).

use crate::error::DomainError;
use crate::kinds::IDENTIFICATION;
pub use mtcal_api::trends::{CheckModel, SummaryPoint, SummaryTrend, TermPoint, TermTrend};
use mtcal_solver::comparison::{self, CheckFunctions, Value};
pub use mtcal_solver::comparison::{Drift, TermDiff};
use mtcal_solver::terms::Term;
use mtcal_solver::tolerance::Figure;
use mtcal_store::{ResultMeta, ResultScalars, SkippedRow, Store};
use serde::Deserialize;
use std::collections::BTreeMap;

/// A stored result's scalars as a check of the solver's result arithmetic.
struct Stored<'a>(&'a ResultScalars);

impl CheckFunctions for Stored<'_> {
    fn coefficients(&self, term: &str) -> Option<&[f64]> {
        self.0.term_coefficients.get(term).map(Vec::as_slice)
    }
    fn coefficient_covariance(&self, term: &str) -> Option<&[Vec<f64>]> {
        self.0.term_covariance.get(term).map(Vec::as_slice)
    }
    fn measured_travel(&self, axis: char) -> Option<[f64; 2]> {
        measured(self.0, axis)
    }
    fn squareness(&self, name: &str) -> Option<f64> {
        self.0.summary.squareness(name).flatten()
    }
    /// Stored as a 1 × 1 covariance under the squareness's name.
    fn squareness_std(&self, name: &str) -> Option<f64> {
        Some(
            self.0
                .term_covariance
                .get(name)?
                .first()?
                .first()?
                .max(0.0)
                .sqrt(),
        )
    }
}

/// Value of term `name` of a stored result at `q_mm`, with its standard uncertainty
/// (`None`: not one of the 18 terms, not identifiable, or outside the measured travel).
pub fn value(s: &ResultScalars, name: &str, q_mm: f64) -> Option<Value> {
    comparison::term_value(&Stored(s), Term::parse(name)?, q_mm)
}

/// Squareness `name` (`EC0Y`, `EB0Z`, `EA0Z`) of a stored result with its standard
/// uncertainty, µrad (`None`: not identified).
pub fn squareness(s: &ResultScalars, name: &str) -> Option<Value> {
    let stored = Stored(s);
    Some(Value {
        value: stored.squareness(name)?,
        u: stored.squareness_std(name),
    })
}

/// Standard uncertainty of squareness `name` (`EC0Y`, `EB0Z`, `EA0Z`) of a stored
/// result, µrad (`None`: not stored).
pub fn squareness_u(s: &ResultScalars, name: &str) -> Option<f64> {
    Stored(s).squareness_std(name)
}

/// `unit` and axis letter of an ISO 230-1 term name (`None` if not one of the 18).
pub fn term_info(name: &str) -> Option<(&'static str, char)> {
    let t = Term::parse(name)?;
    Some((t.unit(), t.axis.letter()))
}

/// Travel the check measured on `axis`, [min, max] mm (`None`: the axis did not move,
/// or the result predates the record).
pub fn measured(s: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    s.measured_travel_mm.get(&axis.to_string()).copied()
}

/// Whether the check measured position `q_mm` of `axis`.
pub fn measured_at(s: &ResultScalars, axis: char, q_mm: f64) -> bool {
    measured(s, axis).is_some_and(|t| comparison::inside(t, q_mm))
}

/// The travel both checks measured on `axis` (`None`: unknown or no overlap).
pub fn common_travel(a: &ResultScalars, b: &ResultScalars, axis: char) -> Option<[f64; 2]> {
    comparison::common_travel(&Stored(a), &Stored(b), axis)
}

/// A sentence stating the measured travel of `axis` in `s`.
pub fn travel_sentence(s: &ResultScalars, axis: char) -> String {
    match measured(s, axis) {
        Some([lo, hi]) => format!("{axis} was measured over [{lo}, {hi}] mm"),
        None => format!("{axis} has no measured travel in this check"),
    }
}

/// Drift between two stored results ([`comparison::drift`]).
pub fn drift(base: &ResultScalars, latest: &ResultScalars) -> Drift {
    comparison::drift(&Stored(base), &Stored(latest))
}

/// Each change since the baseline as a figure of the decision rule
/// ([`mtcal_solver::tolerance::changes`]).
pub fn changes(base: &ResultScalars, latest: &ResultScalars) -> BTreeMap<String, Figure> {
    mtcal_solver::tolerance::changes(&Stored(base), &Stored(latest))
}

/// Checks a diff's step ([`comparison::check_diff_step`]).
pub fn check_diff_step(
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> Result<(), String> {
    comparison::check_diff_step(&Stored(base), &Stored(other), step_mm)
}

/// Term-by-term and squareness differences ([`comparison::diff`]).
pub fn diff(
    base: &ResultScalars,
    other: &ResultScalars,
    step_mm: f64,
) -> (BTreeMap<String, TermDiff>, BTreeMap<String, Option<f64>>) {
    comparison::diff(&Stored(base), &Stored(other), step_mm)
}

/// [`CheckModel`]s by result id: of the checks that are misfits or decided on the
/// explained model.
pub type CheckModels = std::collections::HashMap<String, CheckModel>;

/// The model check of a stored identification document (None: the document is not an
/// identification's). The one reader of the gate: the history's misfit
/// gate and [`check_model`] both take it from here.
pub fn model_check(document: &serde_json::Value) -> Option<mtcal_solver::misfit::ModelCheck> {
    mtcal_solver::identification::IdentificationResult::deserialize(document)
        .ok()
        .map(|d| d.model_check())
}

/// What a trend point or an alert says of the model of a stored document: a misfit and
/// why, or decided on the explained model (neither: not an identification's document,
/// or a model that explains its recording).
pub fn check_model(document: &serde_json::Value) -> CheckModel {
    let Some(c) = model_check(document) else {
        return CheckModel::default();
    };
    CheckModel {
        misfit: c.is_misfit(),
        misfit_reason: c.is_misfit().then(|| c.statement.clone()),
        explained_model: c.decided_on_explained_model().then_some(c.statement),
    }
}

/// The check model to store with a result of `kind` landing with `document`
/// ([`mtcal_store::NewResult::check_model`]): an identification's, else none.
pub fn landing_check_model(kind: &str, document: &serde_json::Value) -> Option<CheckModel> {
    (kind == IDENTIFICATION).then(|| check_model(document))
}

/// [`check_model`] of stored result `id`: as stored beside the result, else (stored
/// before it was kept) read from its document.
pub async fn stored_check_model(
    store: &dyn Store,
    id: &str,
) -> Result<CheckModel, mtcal_store::StoreError> {
    match store.check_model(id).await? {
        Some(m) => Ok(m),
        None => document_check_model(store, id).await,
    }
}

/// [`check_model`] read from stored result `id`'s document (a result stored before its
/// model was kept beside it).
async fn document_check_model(
    store: &dyn Store,
    id: &str,
) -> Result<CheckModel, mtcal_store::StoreError> {
    Ok(check_model(&store.get_result(id).await?.document))
}

/// [`check_model`] of each identification among `results` that is a misfit or decided
/// on the explained model, by result id: as stored beside the results (one statement a
/// machine), a document read only for a result stored before the model was kept.
pub async fn check_models(
    store: &dyn Store,
    results: &[ResultMeta],
) -> Result<CheckModels, mtcal_store::StoreError> {
    let mut stored = std::collections::HashMap::new();
    let mut machines: Vec<&str> = results.iter().map(|r| r.machine_id.as_str()).collect();
    machines.sort_unstable();
    machines.dedup();
    for m in machines {
        stored.extend(store.check_models(m, IDENTIFICATION).await?);
    }
    let mut out = CheckModels::new();
    for r in results.iter().filter(|r| r.kind == IDENTIFICATION) {
        let m = match stored.remove(&r.id).flatten() {
            Some(m) => m,
            None => document_check_model(store, &r.id).await?,
        };
        if m != CheckModel::default() {
            out.insert(r.id.clone(), m);
        }
    }
    Ok(out)
}

/// Learns from their documents the check models of the identifications stored before
/// they were kept beside the results ([`mtcal_store::Results::unknown_check_models`]),
/// `batch` at a time, until none is left; returns how many. Run at start beside the
/// server: until a result's model is stored its readers read its document.
pub async fn fill_check_models(
    store: &dyn Store,
    batch: i64,
) -> Result<usize, mtcal_store::StoreError> {
    let mut done = 0;
    loop {
        let ids = store.unknown_check_models(batch).await?;
        if ids.is_empty() {
            return Ok(done);
        }
        for id in &ids {
            let document = store.get_result(id).await?.document;
            let model =
                crate::blocking::run::<_, mtcal_store::StoreError>(move || check_model(&document))
                    .await?;
            store.set_check_model(id, &model).await?;
        }
        done += ids.len();
    }
}

/// How drift is measured, in words (the fleet routes and page say it).
pub const DRIFT_DEFINITION: &str = "largest change since the baseline result (the machine's \
     chosen baseline, else its first check that is not a misfit) of any term over 41 points of the travel both checks \
     measured, with its standard uncertainty there";

/// A term trend asked for: the term and the positions.
#[derive(Debug, Clone, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::IntoParams))]
#[cfg_attr(feature = "openapi", into_params(parameter_in = Query))]
pub struct TermQuery {
    /// ISO 230-1 name of one of the 18 functions, e.g. `EXX`.
    #[cfg_attr(feature = "openapi", param(pattern = "^E[XYZABC][XYZ]$"))]
    pub term: String,
    /// Positions, mm, comma-separated, e.g. `50,-50`: 1 to 1000 finite numbers.
    #[cfg_attr(
        feature = "openapi",
        param(
            pattern = "^ *[-+]?([0-9]{1,15}(\\.[0-9]{0,15})?|\\.[0-9]{1,15})([eE][-+]?[0-9]{1,2})? *(, *[-+]?([0-9]{1,15}(\\.[0-9]{0,15})?|\\.[0-9]{1,15})([eE][-+]?[0-9]{1,2})? *){0,999}$"
        )
    )]
    pub at: String,
}

/// A term at positions over time, machine `id`'s identifications in time order, each
/// point saying whether its check is a misfit or decided on the explained model (from
/// `known` when the caller has read them, else from the documents).
pub async fn term_trend(
    store: &dyn Store,
    id: &str,
    q: TermQuery,
    known: Option<&CheckModels>,
) -> Result<TermTrend, DomainError> {
    let (unit, _) = term_info(&q.term).ok_or_else(|| {
        let hint = if matches!(q.term.as_str(), "EC0Y" | "EB0Z" | "EA0Z") {
            " (a squareness error, a constant: its trend is in \
             GET /api/v1/machines/{id}/trends/summary)"
        } else {
            ""
        };
        DomainError::Invalid(format!(
            "term {:?} is not one of the 18 ISO 230-1 functions{hint}",
            q.term
        ))
    })?;
    let positions =
        q.at.split(',')
            .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<Vec<_>>>()
            .filter(|v| !v.is_empty() && v.len() <= 1000)
            .ok_or_else(|| {
                DomainError::Invalid(format!(
                    "at {:?}: give 1-1000 comma-separated positions in mm",
                    q.at
                ))
            })?;
    store.get_machine(id).await?;
    let (results, skipped) = store.list_results_checked(id, IDENTIFICATION).await?;
    let (id, warnings) = (
        id.to_string(),
        skipped.iter().map(SkippedRow::warning).collect(),
    );
    let models = models(store, &results, known).await?;
    let mut t = crate::blocking::run::<_, DomainError>(move || {
        evaluate_term(id, q.term, unit, positions, results, warnings)
    })
    .await??;
    for p in &mut t.points {
        p.model = models.get(&p.result_id).cloned().unwrap_or_default();
    }
    Ok(t)
}

/// The check models of `results`: `known`, else read from their documents.
async fn models(
    store: &dyn Store,
    results: &[ResultMeta],
    known: Option<&CheckModels>,
) -> Result<CheckModels, DomainError> {
    Ok(match known {
        Some(k) => k.clone(),
        None => check_models(store, results).await?,
    })
}

/// The term trend's arithmetic (blocking): term `term` (in `unit`) of each of the
/// machine's `results` at `positions`, refused where no check with the term measured.
fn evaluate_term(
    id: String,
    term: String,
    unit: &str,
    positions: Vec<f64>,
    results: Vec<ResultMeta>,
    warnings: Vec<String>,
) -> Result<TermTrend, DomainError> {
    // A position no check with this term measured is refused, saying where they measured.
    let axis = term_info(&term).map_or('X', |(_, a)| a);
    let with_term: Vec<_> = results
        .iter()
        .filter(|r| r.scalars.term_coefficients.contains_key(&term))
        .collect();
    for &p in &positions {
        let inside = |r: &&ResultMeta| measured_at(&r.scalars, axis, p);
        if !with_term.is_empty() && !with_term.iter().any(inside) {
            let latest = with_term.last().expect("not empty");
            return Err(DomainError::OutsideTravel(format!(
                "{} at {p} mm: outside the travel every check of machine {id} measured (in the \
                 latest, {}); terms are not evaluated where they were not measured",
                term,
                travel_sentence(&latest.scalars, axis)
            )));
        }
    }
    let points = results
        .into_iter()
        .map(|r| {
            let at: Vec<_> = positions
                .iter()
                .map(|&p| value(&r.scalars, &term, p))
                .collect();
            TermPoint {
                values: at.iter().map(|v| Some(v.as_ref()?.value)).collect(),
                u: at.iter().map(|v| v.as_ref()?.u).collect(),
                model: Default::default(),
                result_id: r.id,
                measured_at: r.measured_at,
            }
        })
        .collect();
    Ok(TermTrend {
        machine_id: id,
        term,
        unit: unit.into(),
        positions_mm: positions,
        points,
        warnings,
    })
}

/// Residual, conditioning, rank and squareness of machine `id`'s identifications over
/// time, each point saying whether its check is a misfit or decided on the explained
/// model (as [`term_trend`]).
pub async fn summary_trend(
    store: &dyn Store,
    id: &str,
    known: Option<&CheckModels>,
) -> Result<SummaryTrend, DomainError> {
    store.get_machine(id).await?;
    let (results, skipped) = store.list_results_checked(id, IDENTIFICATION).await?;
    let models = models(store, &results, known).await?;
    let points = results
        .into_iter()
        .map(|r| SummaryPoint {
            ec0y_u_urad: squareness_u(&r.scalars, "EC0Y"),
            eb0z_u_urad: squareness_u(&r.scalars, "EB0Z"),
            ea0z_u_urad: squareness_u(&r.scalars, "EA0Z"),
            model: models.get(&r.id).cloned().unwrap_or_default(),
            result_id: r.id,
            measured_at: r.measured_at,
            summary: r.scalars.summary,
        })
        .collect();
    Ok(SummaryTrend {
        machine_id: id.to_string(),
        points,
        warnings: skipped.iter().map(SkippedRow::warning).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use mtcal_store::ResultSummary;

    /// The stored row's squareness and its 1 × 1 variance reach the solver's arithmetic
    /// under the right names (the arithmetic itself is tested in the solver).
    #[test]
    fn stored_scalars_are_read_under_their_names() {
        let mut s = ResultScalars {
            summary: ResultSummary {
                ec0y_urad: Some(5.0),
                ea0z_urad: Some(-2.0),
                ..Default::default()
            },
            ..Default::default()
        };
        s.measured_travel_mm.insert("X".into(), [-50.0, 50.0]);
        s.term_coefficients.insert("EXX".into(), vec![0.01]);
        s.term_covariance.insert("EXX".into(), vec![vec![1e-6]]);
        s.term_covariance.insert("EC0Y".into(), vec![vec![0.04]]);
        let mut l = s.clone();
        l.summary.ec0y_urad = Some(6.5);
        l.summary.ea0z_urad = Some(-2.5);
        l.term_covariance.insert("EA0Z".into(), vec![vec![0.09]]);
        let v = value(&s, "EXX", 50.0).unwrap();
        assert!((v.value - 0.5).abs() < 1e-12 && (v.u.unwrap() - 0.05).abs() < 1e-12);
        assert!(value(&s, "EXX", 60.0).is_none());
        assert!(measured_at(&s, 'X', 50.0) && !measured_at(&s, 'Y', 0.0));
        assert_eq!(Stored(&s).squareness_std("EC0Y"), Some(0.2));
        let (_, sq) = diff(&s, &l, 10.0);
        assert_eq!(sq["EC0Y"], Some(1.5));
        assert_eq!(sq["EA0Z"], Some(-0.5));
        assert_eq!(sq["EB0Z"], None);
        let d = drift(&s, &l);
        assert_eq!(d.worst_term_urad.as_deref(), Some("EC0Y"));
        // EA0Z has no variance in the baseline: its change is not judged.
        let ch = changes(&s, &l);
        assert!(
            ch.contains_key("EC0Y") && !ch.contains_key("EA0Z"),
            "{ch:?}"
        );
    }
}
