//! The rules of the store that do not depend on the database, shared by every backend:
//! record ids, the dataset manifest checksum, machine patches and the baseline rule, and
//! the metadata of a freshly stored result. A backend only runs SQL around them.

use crate::datasets::FileMeta;
use crate::error::{Db, Result, StoreError};
use crate::machines::{Machine, MachinePatch};
use crate::results::{CheckModel, FIGURE_NAME_MAX, Figure, NewResult, ResultMeta, ResultScalars};
use sha2::{Digest, Sha256};

/// A new record id: `<prefix>_<32 hex digits>` (a random UUID).
pub fn new_id(prefix: &str) -> String {
    format!("{prefix}_{}", uuid::Uuid::new_v4().simple())
}

/// A dataset's files with their checksums, and the manifest checksum over them.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// Every file's name, SHA-256 (hex) and size, sorted by name.
    pub files: Vec<FileMeta>,
    /// SHA-256 over the lines `name:sha256\n` of the sorted files.
    pub sha256: String,
    /// Sum of the file sizes, bytes.
    pub total_bytes: i64,
}

impl Manifest {
    /// The manifest of `files` (name, bytes) as uploaded.
    pub fn of(files: &[(String, Vec<u8>)]) -> Manifest {
        let mut listing: Vec<FileMeta> = files
            .iter()
            .map(|(name, bytes)| FileMeta {
                name: name.clone(),
                sha256: hex::encode(Sha256::digest(bytes)),
                size: bytes.len() as i64,
            })
            .collect();
        listing.sort_by(|a, b| (&a.name, &a.sha256).cmp(&(&b.name, &b.sha256)));
        let mut manifest = Sha256::new();
        for f in &listing {
            manifest.update(format!("{}:{}\n", f.name, f.sha256).as_bytes());
        }
        Manifest {
            total_bytes: listing.iter().map(|f| f.size).sum(),
            sha256: hex::encode(manifest.finalize()),
            files: listing,
        }
    }
}

/// Applies `p` to `m`. `baseline` is the stored result `p.baseline_result_id` names (the
/// backend reads it); it must belong to the machine.
pub fn apply_patch(m: &mut Machine, p: &MachinePatch, baseline: Option<&ResultMeta>) -> Result<()> {
    if let Some(b) = &p.baseline_result_id {
        let r = baseline.ok_or_else(|| StoreError::NotFound(format!("result {b}")))?;
        if r.machine_id != m.id {
            return Err(StoreError::Conflict(format!(
                "result {b} belongs to machine {}, not {}",
                r.machine_id, m.id
            )));
        }
        m.baseline_result_id = Some(b.clone());
    }
    if let Some(v) = &p.name {
        m.name = v.clone();
    }
    if let Some(v) = &p.topology {
        m.topology = v.clone();
    }
    if let Some(v) = &p.travel_mm {
        m.travel_mm = v.clone();
    }
    if let Some(v) = &p.site {
        m.site = Some(v.clone());
    }
    if let Some(v) = &p.tags {
        m.tags = v.clone();
    }
    Ok(())
}

/// The JSON text columns of a machine: topology, travel and tags.
pub struct MachineJson {
    pub topology: String,
    pub travel_mm: String,
    pub tags: String,
}

impl MachineJson {
    pub fn of(m: &Machine) -> Result<MachineJson> {
        Ok(MachineJson {
            topology: serde_json::to_string(&m.topology).db()?,
            travel_mm: serde_json::to_string(&m.travel_mm).db()?,
            tags: serde_json::to_string(&m.tags).db()?,
        })
    }
}

/// The columns (`check_gate`, `check_statement`) of a check model.
pub fn check_columns(m: &CheckModel) -> (&'static str, Option<&str>) {
    match (&m.misfit_reason, &m.explained_model) {
        _ if m.misfit => ("misfit", m.misfit_reason.as_deref()),
        (_, Some(s)) => ("explained", Some(s)),
        _ => ("decided", None),
    }
}

/// The check model stored in columns `check_gate` and `check_statement` (`None`: not known).
pub fn check_model(gate: Option<&str>, statement: Option<String>) -> Option<CheckModel> {
    Some(match gate? {
        "misfit" => CheckModel {
            misfit: true,
            misfit_reason: statement,
            explained_model: None,
        },
        "explained" => CheckModel {
            explained_model: statement,
            ..CheckModel::default()
        },
        _ => CheckModel::default(),
    })
}

/// A result about to be stored: its metadata and the JSON text of its document and of
/// its term coefficients.
pub struct ResultRow {
    pub meta: ResultMeta,
    pub document: String,
    pub term_coefficients: String,
    pub measured_travel: String,
    pub term_covariance: String,
}

/// Whether `name` can name a figure: letters, digits, `_` and `.`, 1 to
/// [`FIGURE_NAME_MAX`] bytes.
pub fn valid_figure_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= FIGURE_NAME_MAX
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'.')
}

/// Checks a result's figures before anything is stored: names of letters, digits, `_`
/// and `.` (at most [`FIGURE_NAME_MAX`] bytes), each once; finite values; uncertainties
/// finite and non-negative. A non-finite figure would poison every trend through it.
/// The trend scalars of a result must be finite: one non-finite coefficient would make
/// every later trend, difference and fleet ranking of the machine unanswerable, so such a
/// result is refused (nothing stored) instead.
pub fn check_scalars(s: &ResultScalars) -> Result<()> {
    let named = [
        ("residual_rms_um", s.summary.residual_rms_um),
        ("ec0y_urad", s.summary.ec0y_urad),
        ("eb0z_urad", s.summary.eb0z_urad),
        ("ea0z_urad", s.summary.ea0z_urad),
    ];
    for (name, v) in named {
        if v.is_some_and(|v| !v.is_finite()) {
            return Err(StoreError::Invalid(format!("{name} is not finite")));
        }
    }
    for (term, c) in &s.term_coefficients {
        if c.iter().any(|v| !v.is_finite()) {
            return Err(StoreError::Invalid(format!(
                "term {term}: a coefficient is not finite"
            )));
        }
    }
    for (axis, [lo, hi]) in &s.measured_travel_mm {
        if !(lo.is_finite() && hi.is_finite() && lo < hi && hi - lo <= 1e5) {
            return Err(StoreError::Invalid(format!(
                "measured travel of {axis}: [{lo}, {hi}] mm must be finite, increasing, at most 100 m"
            )));
        }
    }
    for (term, cov) in &s.term_covariance {
        // A squareness value's variance is a 1 × 1 covariance.
        let squareness = s.summary.squareness(term);
        let n = match squareness {
            Some(v) => usize::from(v.is_some()),
            None => s.term_coefficients.get(term).map_or(0, Vec::len),
        };
        if cov.len() != n
            || cov
                .iter()
                .any(|row| row.len() != n || row.iter().any(|v| !v.is_finite()))
        {
            return Err(StoreError::Invalid(format!(
                "term {term}: the covariance must be a finite {n} × {n} matrix (one row and column per coefficient)"
            )));
        }
    }
    Ok(())
}

pub fn check_figures(figures: &[Figure]) -> Result<()> {
    let mut seen = std::collections::BTreeSet::new();
    for f in figures {
        if !valid_figure_name(&f.name) {
            return Err(StoreError::Invalid(format!("figure name {:?}", f.name)));
        }
        if !seen.insert(f.name.as_str()) {
            return Err(StoreError::Invalid(format!(
                "figure {} given twice",
                f.name
            )));
        }
        if !f.value.is_finite() || f.u.is_some_and(|u| !u.is_finite() || u < 0.0) {
            return Err(StoreError::Invalid(format!(
                "figure {}: value {} and uncertainty {:?} must be finite (u ≥ 0)",
                f.name, f.value, f.u
            )));
        }
    }
    Ok(())
}

impl ResultRow {
    /// A new result of job `job_id`, created now; its figures checked ([`check_figures`]).
    pub fn new(job_id: &str, r: &NewResult) -> Result<ResultRow> {
        check_figures(&r.figures)?;
        check_scalars(&r.scalars)?;
        Ok(ResultRow {
            meta: ResultMeta {
                id: new_id("res"),
                job_id: job_id.to_string(),
                machine_id: r.machine_id.clone(),
                dataset_id: r.dataset_id.clone(),
                kind: r.kind.clone(),
                measured_at: r.measured_at.clone(),
                created_at: crate::now_rfc3339(),
                scalars: r.scalars.clone(),
                excluded: None,
            },
            document: serde_json::to_string(&r.document).db()?,
            term_coefficients: serde_json::to_string(&r.scalars.term_coefficients).db()?,
            measured_travel: serde_json::to_string(&r.scalars.measured_travel_mm).db()?,
            term_covariance: serde_json::to_string(&r.scalars.term_covariance).db()?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn non_finite_scalars_are_refused() {
        let mut s = ResultScalars::default();
        assert!(check_scalars(&s).is_ok());
        s.term_coefficients
            .insert("EXX".into(), vec![1.0, f64::NAN]);
        let e = check_scalars(&s).unwrap_err().to_string();
        assert!(e.contains("term EXX"), "{e}");
        s.term_coefficients.clear();
        s.summary.ec0y_urad = Some(f64::INFINITY);
        assert!(
            check_scalars(&s)
                .unwrap_err()
                .to_string()
                .contains("ec0y_urad")
        );
    }

    #[test]
    fn manifest_is_the_sha256_of_the_sorted_listing() {
        // sha256("") and sha256("abc") are the FIPS 180-2 test vectors.
        let m = Manifest::of(&[("b.csv".into(), b"abc".to_vec()), ("a.json".into(), vec![])]);
        let empty = "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855";
        let abc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad";
        assert_eq!(
            m.files.iter().map(|f| f.name.as_str()).collect::<Vec<_>>(),
            ["a.json", "b.csv"]
        );
        assert_eq!(
            (m.files[0].sha256.as_str(), m.files[1].sha256.as_str()),
            (empty, abc)
        );
        assert_eq!(m.total_bytes, 3);
        let listing = format!("a.json:{empty}\nb.csv:{abc}\n");
        assert_eq!(m.sha256, hex::encode(Sha256::digest(listing.as_bytes())));
        // Upload order does not matter.
        let n = Manifest::of(&[("a.json".into(), vec![]), ("b.csv".into(), b"abc".to_vec())]);
        assert_eq!(n, m);
    }

    fn machine(id: &str) -> Machine {
        Machine {
            id: id.into(),
            name: "m".into(),
            topology: json!({}),
            travel_mm: Default::default(),
            site: None,
            tags: vec![],
            baseline_result_id: None,
            created_at: String::new(),
            updated_at: String::new(),
        }
    }

    fn meta(id: &str, machine_id: &str) -> ResultMeta {
        ResultMeta {
            id: id.into(),
            job_id: "job".into(),
            machine_id: machine_id.into(),
            dataset_id: None,
            kind: "identification".into(),
            measured_at: String::new(),
            created_at: String::new(),
            scalars: Default::default(),
            excluded: None,
        }
    }

    #[test]
    fn a_baseline_must_belong_to_the_machine() {
        let mut m = machine("M1");
        let p = MachinePatch {
            baseline_result_id: Some("res_b".into()),
            name: Some("renamed".into()),
            ..Default::default()
        };
        let err = apply_patch(&mut m, &p, Some(&meta("res_b", "M2"))).unwrap_err();
        assert!(matches!(err, StoreError::Conflict(_)), "{err}");
        assert!(matches!(
            apply_patch(&mut m, &p, None),
            Err(StoreError::NotFound(_))
        ));
        assert_eq!(
            (m.name.as_str(), m.baseline_result_id.as_deref()),
            ("m", None)
        );
        apply_patch(&mut m, &p, Some(&meta("res_b", "M1"))).unwrap();
        assert_eq!(
            (m.name.as_str(), m.baseline_result_id.as_deref()),
            ("renamed", Some("res_b"))
        );
    }
}
