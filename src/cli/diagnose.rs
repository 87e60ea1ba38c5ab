//! `mtcal diagnose PATH [--json] [--plots DIR] [--fit-fraction F] [--predictions CSV]`:
//! mismatch diagnosis of a session folder, a positioning-run CSV or a drift-log CSV (the
//! kind is detected from the content). Human summary by default; `--json` prints the
//! diagnosis result document. For drift logs, `--fit-fraction` sets the share of the
//! recording the models are fitted on (the rest judges them) and `--predictions` writes
//! the models' predictions at every sample (`docs/diagnosis-series.md`, "Prediction export").

use super::BadInput;
use anyhow::Context;
use mtcal_formats::DatasetKind;
use mtcal_solver::diagnosis::series::{self, SeriesOptions};
use mtcal_solver::diagnosis::{
    DiagnoseOptions, DiagnosisResult, Finding, PlotData, Progress, Verdict,
};
use mtcal_solver::positioning_check::{DiagnosisDocument, check_positioning};
use mtcal_solver::text::{num, with_std};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A session folder, a positioning-run CSV or a drift-log CSV (`.csv.gz` too).
    pub path: PathBuf,
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Print the diagnosis result (JSON) instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// Write every plot as `<id>.svg` into this directory.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// Machine id written into the result (default: the session's, else the file name).
    #[arg(long)]
    pub machine_id: Option<String>,
    /// Drift logs: fraction of the recording the models are fitted on, from the start
    /// (0.2–0.9, default 0.6); the rest is held out to judge them.
    #[arg(long, value_name = "F")]
    pub fit_fraction: Option<f64>,
    /// Drift logs: write the models' predictions at every sample to this CSV
    /// (t_s, part, then per channel measured, model and compensation, µm).
    #[arg(long, value_name = "CSV")]
    pub predictions: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let limits = args.read.limits();
    let path = &args.path;
    mtcal_formats::stat_path(path)?;
    // A CSV that looks like positioning runs or a drift log but breaks its format is read
    // with that kind's reader, which names what is wrong (file, line, column and rule).
    let kind = mtcal_formats::sniff_path(path)
        .or_else(|| mtcal_formats::sniff::resembled_path(path))
        .ok_or_else(|| {
            BadInput(format!(
                "{}: not a session folder (session.json), a positioning-run CSV \
             (axis,run,direction,target_mm,deviation_um) or a drift-log CSV (t_s, <name>_um, ...)",
                path.display()
            ))
        })?;
    let machine_id = args.machine_id.clone().unwrap_or_else(|| {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        name.trim_end_matches(".gz")
            .trim_end_matches(".csv")
            .to_string()
    });
    let mut opts = SeriesOptions::default();
    if kind != DatasetKind::DriftLog && (args.fit_fraction.is_some() || args.predictions.is_some())
    {
        return Err(BadInput(format!(
            "{}: --fit-fraction and --predictions apply to drift logs only",
            path.display()
        ))
        .into());
    }
    if let Some(f) = args.fit_fraction {
        if !(0.2..=0.9).contains(&f) {
            return Err(BadInput(format!("--fit-fraction {f}: must lie in [0.2, 0.9]")).into());
        }
        opts.train_fraction = f;
    }
    // ISO 230-2 figures accompany the diagnosis of positioning runs (in the summary, and
    // as the document's `iso230_2`).
    let doc: DiagnosisDocument = match kind {
        DatasetKind::Positioning => {
            let runs = mtcal_formats::read_positioning_path(path, &limits)?;
            with_bar(|p| check_positioning(&runs, &machine_id, &opts, p))
                .map_err(|e| BadInput(format!("{}: {e}", path.display())))?
        }
        DatasetKind::DriftLog => {
            let log = mtcal_formats::read_drift_log_path(path, &limits)?;
            let (r, pred) = with_bar(|p| {
                series::drift::diagnose_drift_log_with_progress(&log, &machine_id, &opts, p)
            })
            .map_err(|e| BadInput(format!("{}: {e}", path.display())))?;
            if let Some(out) = &args.predictions {
                let f = std::fs::File::create(out)
                    .with_context(|| format!("creating {}", out.display()))?;
                let mut w = std::io::BufWriter::new(f);
                mtcal_formats::write_drift_predictions(&mut w, &pred)
                    .and_then(|()| w.flush())
                    .with_context(|| format!("writing {}", out.display()))?;
                if !args.json {
                    super::out::noteln!(
                        "wrote the predictions ({} samples) to {}",
                        pred.t_s.len(),
                        out.display()
                    );
                }
            }
            r.into()
        }
        DatasetKind::Session => {
            let session = mtcal_formats::read_session_dir(path, &limits)?;
            let r = with_bar(|p| {
                mtcal_solver::diagnosis::diagnose_session_with_progress(
                    &session,
                    &DiagnoseOptions::default(),
                    p,
                )
            });
            let mut r = r.map_err(|e| BadInput(format!("{}: {e}", path.display())))?;
            if let Some(id) = &args.machine_id {
                r.machine_id = id.clone();
            }
            r.into()
        }
        other => {
            return Err(BadInput(format!(
                "{}: a {other:?} file cannot be diagnosed on its own; give a session folder, a \
                 positioning-run CSV or a drift-log CSV",
                path.display()
            ))
            .into());
        }
    };
    let result = &doc.diagnosis;
    if let Some(dir) = &args.plots {
        let written = write_svgs(&result.plots, dir)?;
        if !args.json {
            super::out::noteln!("wrote {} plot(s) to {}", written.len(), dir.display());
        }
    }
    super::out::document(args.json, &doc, |doc| {
        let mut s = summary(&doc.diagnosis);
        s.push_str(&super::standards::summary(
            &mtcal_solver::standards::Standards {
                iso230_2: doc.iso230_2.clone(),
                not_evaluated: doc.not_evaluated.clone(),
                ..Default::default()
            },
        ));
        s
    })?;
    Ok(ExitCode::SUCCESS)
}

/// Runs a diagnosis with a progress bar on stderr (drawn only when it is a terminal):
/// the phase and the fraction of the work done.
pub fn with_bar<T>(diagnose: impl FnOnce(&mut dyn Progress) -> T) -> T {
    let bar = indicatif::ProgressBar::new(100);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:30} {pos}% {msg}",
        )
        .expect("valid template"),
    );
    let r = diagnose(&mut |phase: &str, f: f64| {
        bar.set_position((f * 100.0).round() as u64);
        bar.set_message(phase.to_string());
    });
    bar.finish_and_clear();
    r
}

/// Renders every plot into `dir` as `<stem>.svg` ([`mtcal_views::plots::file_stem`]), the
/// polar ones on one radial scale as on the diagnosis page; returns the paths written. A
/// folder that cannot be written is bad input.
fn write_svgs(plots: &[PlotData], dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    let err = |p: &Path, e: std::io::Error| BadInput(format!("{}: cannot write: {e}", p.display()));
    std::fs::create_dir_all(dir).map_err(|e| err(dir, e))?;
    let mut paths = vec![];
    for (p, svg) in plots.iter().zip(mtcal_views::plots::render_svgs(plots)) {
        let path = dir.join(format!("{}.svg", mtcal_views::plots::file_stem(p)));
        std::fs::write(&path, svg).map_err(|e| err(&path, e))?;
        paths.push(path);
    }
    Ok(paths)
}

/// " (axis)" of a finding that names one.
fn axis_of(f: &Finding) -> String {
    f.axis_label()
        .map(|a| format!(" ({a})"))
        .unwrap_or_default()
}

/// A finding's undetermined parameters, one line per sentence of what would decide them
/// (the same shape for sessions, positioning runs and drift logs).
fn undetermined_lines(s: &mut String, f: &Finding) {
    use std::fmt::Write;
    let mut groups: Vec<(&str, Vec<String>)> = vec![];
    for u in &f.undetermined {
        let item = match u.std {
            Some(sd) => format!("{} = {}", u.name, with_std(u.value, sd, 2, false)),
            None => format!("{} = {} (no finite bound)", u.name, num(u.value)),
        };
        match groups.iter_mut().find(|(d, _)| *d == u.decide) {
            Some((_, v)) => v.push(item),
            None => groups.push((&u.decide, vec![item])),
        }
    }
    for (decide, items) in groups {
        let _ = writeln!(s, "  undetermined: {} ({decide})", items.join(", "));
    }
}

/// Parameters as `name = value ± σ` (σ from `std_name`), or `name = value` without one.
pub fn in_words(parameters: &std::collections::BTreeMap<String, f64>) -> Vec<String> {
    parameters
        .iter()
        .filter(|(k, _)| !k.starts_with("std_"))
        .map(|(k, v)| match parameters.get(&format!("std_{k}")) {
            Some(sd) => format!("{k} = {}", with_std(*v, *sd, 2, false)),
            None => format!("{k} = {}", num(*v)),
        })
        .collect()
}

/// The human summary: verdict, baseline, where, findings, what remains.
pub fn summary(r: &DiagnosisResult) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let verdict = match r.verdict {
        Verdict::Consistent => "consistent (the rigid model explains the data to noise level)",
        Verdict::Explained => "explained (the findings bring the fit to noise level)",
        Verdict::PartlyExplained => "partly explained",
    };
    let _ = writeln!(s, "diagnosis of {} ({}): {verdict}", r.machine_id, r.source);
    let b = &r.baseline;
    let _ = writeln!(
        s,
        "rigid model: residual RMS {} µm, held-out RMS {} µm, noise floor {} µm",
        num(b.residual_rms_um),
        num(b.heldout_rms_um),
        num(b.noise_estimate_um)
    );
    if !r.mismatch.is_empty() {
        let _ = writeln!(s, "where the misfit is:");
        for m in &r.mismatch {
            let _ = writeln!(s, "  {:>3.0} %  {}", 100.0 * m.share_of_misfit, m.where_);
        }
    }
    for f in &r.findings {
        let _ = writeln!(
            s,
            "finding: {}{}: held-out RMS {} → {} µm",
            f.effect,
            axis_of(f),
            num(f.heldout_rms_um.before),
            num(f.heldout_rms_um.after)
        );
        let _ = writeln!(s, "  physics: {}", f.physics);
        let params = in_words(&f.parameters);
        let _ = writeln!(s, "  parameters: {}", params.join(", "));
        undetermined_lines(&mut s, f);
        for r in &f.rivals {
            let _ = writeln!(s, "  rival: {}", r.in_words());
        }
        let _ = writeln!(s, "  evidence: {}", f.evidence);
    }
    for f in &r.possible {
        let _ = writeln!(s, "possible, undetermined: {}{}", f.effect, axis_of(f));
        undetermined_lines(&mut s, f);
    }
    for why in &r.rejected {
        let _ = writeln!(s, "rejected: {why}");
    }
    for u in &r.unexplained {
        let _ = writeln!(s, "unexplained: {u}");
    }
    s
}
