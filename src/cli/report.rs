//! `mtcal report RESULT.json --out check.html [--diagnosis DIAGNOSIS.json] [--tolerances
//! LIMITS.json]`: the check report, one self-contained HTML page that prints on A4
//! (docs/report.md); of an identification, a positioning-run diagnosis or a cradle check.

use super::BadInput;
use super::export::read_identification;
use anyhow::Context;
use mtcal_solver::cradle::CradleResult;
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::positioning_check::DiagnosisDocument;
use mtcal_solver::tolerance::{Assessment, Limits, evaluate, identification_figures};
use mtcal_views::pages::report::{
    CheckReport, CradleCheckReport, PositioningReport, ReportDiagnosis, check_report,
    cradle_report, positioning_report,
};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// An identification result (`mtcal identify --json`, or a stored result), or a
    /// positioning-run diagnosis (`mtcal diagnose RUNS.csv --json`), or a cradle result
    /// (`mtcal cradle --json`).
    pub result: PathBuf,
    /// Where to write the page (stdout without it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// A diagnosis of the same check (`mtcal diagnose --json`): its findings go in the
    /// report.
    #[arg(long, value_name = "DIAGNOSIS.json")]
    pub diagnosis: Option<PathBuf>,
    /// A tolerance profile's limits (`{"terms": {"EXX": 5}, "squareness": {…},
    /// "standards": {"iso230_2.X.E_um": 8}}`, µm and µrad): the figures are decided
    /// against them (ISO 14253-1, U = 2u). Without it every figure says "no tolerance".
    #[arg(long, value_name = "LIMITS.json")]
    pub tolerances: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let (v, doc) = read_document(&args)?;
    if let Some(page) = positioning(&args, &v, &doc)? {
        return write(&args, page);
    }
    if let Some(page) = cradle(&args, doc)? {
        return write(&args, page);
    }
    let doc = read_identification(&args.result)?;
    let diagnosis: Option<ReportDiagnosis> = args
        .diagnosis
        .as_deref()
        .map(|p| {
            super::read_json::<DiagnosisResult>(p, "diagnosis").map(|d| ReportDiagnosis {
                // The file's name: a report does not print the reader's directories.
                id: p.file_name().map_or_else(
                    || p.display().to_string(),
                    |n| n.to_string_lossy().into_owned(),
                ),
                stored: false,
                doc: Ok(d),
            })
        })
        .transpose()?;
    if let Some(ReportDiagnosis { doc: Ok(d), .. }) = &diagnosis
        && d.machine_id != doc.machine_id
    {
        return Err(BadInput(format!(
            "the diagnosis is of machine {}, the result of {}",
            d.machine_id, doc.machine_id
        ))
        .into());
    }
    let verdict = match &args.tolerances {
        Some(p) => {
            let limits: Limits = super::read_json(p, "tolerances")?;
            limits
                .validate()
                .map_err(|m| BadInput(format!("{}: {m}", p.display())))?;
            let how = Assessment::of_identification(&doc, Default::default());
            Some(evaluate(&limits, &identification_figures(&doc), &how))
        }
        None => None,
    };
    let now = mtcal_store::now_rfc3339();
    let page = check_report(&CheckReport {
        doc: &doc,
        result_id: None,
        generated_at: &now,
        verdict: verdict.as_ref(),
        diagnosis: diagnosis.as_ref(),
    })
    .into_string();
    write(&args, page)
}

/// Writes the page to `--out` (then says so on stderr, as the other commands that write
/// a file do) or to stdout.
fn write(args: &Args, page: String) -> anyhow::Result<ExitCode> {
    match &args.out {
        Some(p) => {
            std::fs::write(p, &page).with_context(|| format!("writing {}", p.display()))?;
            super::out::noteln!("wrote the report ({} bytes) to {}", page.len(), p.display());
        }
        None => super::out::write(&page)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// The result document in `args.result` and, for a stored result, the whole stored
/// value (its `meta` beside the `document`).
fn read_document(args: &Args) -> anyhow::Result<(serde_json::Value, serde_json::Value)> {
    let v: serde_json::Value = super::read_json(&args.result, "result")?;
    let doc = match v.get("document") {
        Some(d) if v.get("meta").is_some() => d.clone(),
        _ => v.clone(),
    };
    Ok((v, doc))
}

/// An error unless the report is of an identification: `--diagnosis` and
/// `--tolerances` apply to identification results only.
fn identification_options_only(args: &Args, what: &str) -> anyhow::Result<()> {
    if args.diagnosis.is_some() || args.tolerances.is_some() {
        return Err(BadInput(format!(
            "{}: {what} is its own report; --diagnosis and --tolerances apply to identification results",
            args.result.display()
        ))
        .into());
    }
    Ok(())
}

/// The report of a positioning-run diagnosis (`mtcal diagnose RUNS.csv --json`, or a
/// stored one): its ISO 230-2 figures and its findings. `None` for another result.
fn positioning(
    args: &Args,
    v: &serde_json::Value,
    doc: &serde_json::Value,
) -> anyhow::Result<Option<String>> {
    if doc.get("kind").and_then(|k| k.as_str()) != Some("diagnosis")
        || doc.get("source").and_then(|k| k.as_str()) != Some("positioning")
    {
        return Ok(None);
    }
    identification_options_only(args, "a positioning-run diagnosis")?;
    let d: DiagnosisDocument = serde_json::from_value(doc.clone()).map_err(|e| {
        BadInput(format!(
            "{}: not a positioning-run diagnosis: {e}",
            args.result.display()
        ))
    })?;
    let measured = v["meta"]["measured_at"].as_str().unwrap_or("").to_string();
    let now = mtcal_store::now_rfc3339();
    Ok(Some(
        positioning_report(&PositioningReport {
            doc: &d,
            result_id: v["meta"]["id"].as_str(),
            measured_at: &measured,
            generated_at: &now,
        })
        .into_string(),
    ))
}

/// The report of a cradle check (`mtcal cradle --json`, or a stored one). `None` for
/// another result.
fn cradle(args: &Args, doc: serde_json::Value) -> anyhow::Result<Option<String>> {
    if doc.get("kind").and_then(|k| k.as_str()) != Some("cradle") {
        return Ok(None);
    }
    identification_options_only(args, "a cradle result")?;
    let c: CradleResult = serde_json::from_value(doc).map_err(|e| {
        BadInput(format!(
            "{}: not a cradle result: {e}",
            args.result.display()
        ))
    })?;
    let now = mtcal_store::now_rfc3339();
    Ok(Some(
        cradle_report(&CradleCheckReport {
            doc: &c,
            result_id: None,
            generated_at: &now,
        })
        .into_string(),
    ))
}
