//! `mtcal standards PATH [--json]`: the figures of ISO 230-2 and ISO 230-4 of a session
//! folder (line passes and circle runs) or ISO 230-2 of a positioning-run CSV. Human
//! summary by default; `--json` prints the `standards` document (the same object as the
//! identification result's `standards`).

use super::BadInput;
use mtcal_formats::DatasetKind;
use mtcal_solver::standards::{self, Standards};
use mtcal_solver::text::num;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// A session folder or a positioning-run CSV (`.csv.gz` too).
    pub path: PathBuf,
    #[command(flatten)]
    pub read: super::ReadArgs,
    /// Print the figures (JSON) instead of the summary.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let limits = args.read.limits();
    let path = &args.path;
    mtcal_formats::stat_path(path)?;
    // A CSV that looks like positioning runs but breaks their format is read with their
    // reader, which names the missing column (file, line, column and rule).
    let kind = mtcal_formats::sniff_path(path).or_else(|| {
        mtcal_formats::sniff::resembled_path(path).filter(|k| *k == DatasetKind::Positioning)
    });
    let st = match kind {
        Some(DatasetKind::Session) => {
            standards::from_session(&mtcal_formats::read_session_dir(path, &limits)?)
        }
        Some(DatasetKind::Positioning) => {
            standards::from_positioning_runs(&mtcal_formats::read_positioning_path(path, &limits)?)
        }
        _ => {
            return Err(BadInput(format!(
                "{}: not a session folder (session.json) or a positioning-run CSV \
                 (axis,run,direction,target_mm,deviation_um)",
                path.display()
            ))
            .into());
        }
    };
    super::out::document(args.json, &st, summary)?;
    Ok(ExitCode::SUCCESS)
}

/// The figures as text tables: ISO 230-2 per axis, ISO 230-4 per plane and direction,
/// then what could not be evaluated.
pub fn summary(st: &Standards) -> String {
    let mut s = String::new();
    if !st.iso230_2.is_empty() {
        let _ = writeln!(
            s,
            "\nISO 230-2 (µm)  {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7}",
            "B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M", "A_up", "A_down", "A"
        );
        // A figure this plan cannot determine is printed as "—", its reason once below.
        let mut unavailable: Vec<(&str, Vec<&str>)> = vec![];
        for f in &st.iso230_2 {
            let _ = write!(s, "axis {}          ", f.axis);
            for (name, v) in mtcal_solver::standards::iso230_2::FIGURES
                .iter()
                .zip(f.values())
            {
                match (f.not_available(name), v) {
                    (Some(why), _) => {
                        let _ = write!(s, " {:>7}", "—");
                        match unavailable.iter_mut().find(|(w, _)| *w == why) {
                            Some((_, names)) if !names.contains(name) => names.push(name),
                            Some(_) => {}
                            None => unavailable.push((why, vec![name])),
                        }
                    }
                    (None, v) => {
                        let _ = write!(s, " {:>7}", v.map_or("—".into(), num));
                    }
                }
            }
            let from = match (&f.file, f.head_offset_mm) {
                (Some(file), Some(t)) => format!(
                    "line passes of {file}, head offset ({}, {}, {}) mm",
                    num(t[0]),
                    num(t[1]),
                    num(t[2])
                ),
                _ => "positioning runs".into(),
            };
            let _ = writeln!(
                s,
                "\n  {} targets, {} runs ({} up, {} down per target), {from}",
                f.targets, f.runs, f.n_up, f.n_down
            );
            for n in &f.notes {
                let _ = writeln!(s, "  note: {n}");
            }
            if let Some(w) = &f.without_outlying {
                let _ = write!(
                    s,
                    "  without the {} outlying reading(s), not the standard's figures:\n                ",
                    w.readings.len()
                );
                for name in mtcal_solver::standards::iso230_2::FIGURES {
                    if f.not_available(name).is_some() {
                        let _ = write!(s, " {:>7}", "—");
                    } else {
                        let _ = write!(
                            s,
                            " {:>7}",
                            w.figures.get(name).map_or("—".into(), |v| num(*v))
                        );
                    }
                }
                let _ = writeln!(s);
            }
        }
        for (why, names) in unavailable {
            let _ = writeln!(s, "  — not available ({}): {why}", names.join(", "));
        }
    }
    if !st.iso230_4.is_empty() {
        let _ = writeln!(
            s,
            "\nISO 230-4 (µm)  {:<4} {:>8} {:>10} {:>8} {:>8} {:>9} {:>8} {:>8} {:>8}",
            "dir", "Ø mm", "F mm/min", "start °", "G", "mean rad", "F_max", "F_min", "H"
        );
        for f in &st.iso230_4 {
            for d in &f.directions {
                let _ = writeln!(
                    s,
                    "plane {:<9} {:<4} {:>8} {:>10} {:>8} {:>8} {:>9} {:>8} {:>8}",
                    format!("{:?}", f.plane),
                    d.direction,
                    num(f.diameter_mm),
                    num(d.feed_mm_min),
                    num(d.start_angle_deg),
                    num(d.g_um),
                    num(d.mean_radial_um),
                    num(d.f_max_um),
                    num(d.f_min_um)
                );
            }
            if let Some(b) = &f.bidirectional {
                let _ = writeln!(
                    s,
                    "plane {:<9} {:<4} {:>8} {:>10} {:>8} {:>8} {:>9} {:>8} {:>8} {:>8}",
                    format!("{:?}", f.plane),
                    "bi",
                    "",
                    "",
                    "",
                    num(b.g_um),
                    num(b.mean_radial_um),
                    num(b.f_max_um),
                    num(b.f_min_um),
                    num(b.h_um)
                );
            }
            let t = f.head_offset_mm;
            let _ = writeln!(
                s,
                "  from {}, head offset ({}, {}, {}) mm",
                f.file,
                num(t[0]),
                num(t[1]),
                num(t[2])
            );
            for n in &f.notes {
                let _ = writeln!(s, "  note: {n}");
            }
        }
    }
    for n in &st.not_evaluated {
        let _ = writeln!(s, "not evaluated: {} {}: {}", n.standard, n.what, n.reason);
    }
    s
}
