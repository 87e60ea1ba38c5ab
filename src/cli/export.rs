//! `mtcal export RESULT.json --format isg|etalon|heidenhain|csv|linuxcnc [--step-mm S]
//! [--diagnosis D.json] [--out F]`: the compensation table of an identification result
//! for a controller (docs/compensation.md). Only identifiable terms, only over the
//! measured travel; the file's header comment states the sign convention (compensation =
//! −error) and names the terms left out; with a diagnosis of the same recording, the
//! reversal and thermal coefficients it found (a result of the explained model: its own
//! fitted physics, any diagnosis given aside).

use super::BadInput;
use anyhow::Context;
use mtcal_formats::compensation::{Compensation, DEFAULT_STEP_MM, ExportError, Format};
use mtcal_solver::diagnosis::DiagnosisResult;
use mtcal_solver::identification::IdentificationResult;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// An identification result: the document `mtcal identify --json` prints, or a stored
    /// result as `GET /api/v1/results/{id}` returns it.
    pub result: PathBuf,
    /// isg, etalon, heidenhain, csv or linuxcnc.
    #[arg(long)]
    pub format: String,
    /// A diagnosis of the same recording (`mtcal diagnose --json`, or a stored diagnosis
    /// result): the reversal and thermal coefficients it found go into the table (csv,
    /// linuxcnc) or are named in its header (the other formats). A result of the explained
    /// model (`mtcal identify --explain`) carries its own physics, which is used instead.
    #[arg(long)]
    pub diagnosis: Option<PathBuf>,
    /// Spacing of the table's positions, mm (from the start of each measured travel; the
    /// end is always included).
    #[arg(long, default_value_t = DEFAULT_STEP_MM)]
    pub step_mm: f64,
    /// Make the table although the result's model does not explain its recording (the
    /// misfit gate); the table's first header line then says why it is not for use
    /// without review.
    #[arg(long)]
    pub force: bool,
    /// Write the file here instead of to stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let format = Format::parse(&args.format).map_err(BadInput)?;
    let doc = read_identification(&args.result)?;
    let refused = |e| match e {
        ExportError::BadStep(m) => BadInput(format!("--step-mm: {m}")),
        e @ (ExportError::NothingIdentifiable(_) | ExportError::ModelMisfit(_)) => {
            BadInput(format!("{}: {e}", args.result.display()))
        }
    };
    let findings = match &args.diagnosis {
        Some(p) => read_diagnosis(p)?.findings,
        None => vec![],
    };
    // A result of the explained model (`mtcal identify --explain`): its own jointly
    // fitted physics, as the service's export takes it.
    let findings = match &doc.explained {
        Some(m) => mtcal_formats::compensation::physics::explained_findings(m),
        None => findings,
    };
    let table = Compensation::from_result(&doc, args.step_mm, args.force)
        .map_err(refused)?
        .with_findings(&findings);
    format.check(&table).map_err(refused)?;
    let text = format.write(&table);
    match &args.out {
        Some(p) => std::fs::write(p, text).with_context(|| format!("writing {}", p.display()))?,
        None => super::out::write(&text)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// An identification result from a file: the document itself, or a stored result
/// (`{"meta": …, "document": …}`); anything else is a bad input naming the file.
pub fn read_identification(path: &Path) -> anyhow::Result<IdentificationResult> {
    let v: serde_json::Value = super::read_json(path, "result")?;
    let doc = match v.get("document") {
        Some(d) if v.get("meta").is_some() => d.clone(),
        _ => v,
    };
    let kind = doc.get("kind").and_then(|k| k.as_str()).unwrap_or("");
    if kind != "identification" {
        return Err(BadInput(format!(
            "{}: a result of kind `{kind}`; an identification result is needed",
            path.display()
        ))
        .into());
    }
    serde_json::from_value(doc).map_err(|e| {
        BadInput(format!(
            "{}: not an identification result: {e}",
            path.display()
        ))
        .into()
    })
}

/// A diagnosis result from a file: the document itself, or a stored result.
fn read_diagnosis(path: &Path) -> anyhow::Result<DiagnosisResult> {
    let v: serde_json::Value = super::read_json(path, "diagnosis")?;
    let doc = match v.get("document") {
        Some(d) if v.get("meta").is_some() => d.clone(),
        _ => v,
    };
    // A positioning-run check stores its diagnosis inside (`diagnosis`).
    let doc = match doc.get("diagnosis") {
        Some(d) if doc.get("kind").is_none() => d.clone(),
        _ => doc,
    };
    serde_json::from_value(doc)
        .map_err(|e| BadInput(format!("{}: not a diagnosis result: {e}", path.display())).into())
}
