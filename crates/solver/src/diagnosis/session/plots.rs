//! The figures of a session's diagnosis, before and after its findings.

use crate::diagnosis::design::{Design, RunInfo};
use crate::diagnosis::{PlotData, PlotKind, PlotSeries};
use crate::session::TestKind;

/// The first circle run of the session, whose radial residual is plotted.
fn first_circle(d: &Design) -> Option<&RunInfo> {
    d.runs
        .iter()
        .find(|r| matches!(r.test, TestKind::CircleCcw | TestKind::CircleCw))
}

/// The series of one residual `r` in the figures of [`plots`]: the first circle's radial
/// residual against its angle (when the session has a circle) and the RMS of each run
/// against its middle time. Formed when the residual is at hand, so that the residual
/// need not be kept for the report.
pub(crate) struct Series {
    polar: Option<PlotSeries>,
    per_run: PlotSeries,
}

impl Series {
    pub fn of(d: &Design, r: &[f64], name: &str) -> Series {
        let polar = first_circle(d).map(|run| {
            let (u, v) = d.plane_axes[run.plane_idx];
            let mut x = Vec::new();
            let mut y = Vec::new();
            for s in run.start..run.end {
                let q = d.fields.q(s);
                let th = q[v.index()].atan2(q[u.index()]);
                x.push(th.to_degrees().rem_euclid(360.0));
                y.push(r[2 * s] * th.cos() + r[2 * s + 1] * th.sin());
            }
            PlotSeries {
                name: name.into(),
                x,
                y,
            }
        });
        let mut x = Vec::new();
        let mut y = Vec::new();
        for run in &d.runs {
            let rows = 2 * run.start..2 * run.end;
            let n = rows.len();
            x.push(0.5 * (d.fields.t_s[run.start] + d.fields.t_s[run.end - 1]));
            y.push((rows.map(|i| r[i] * r[i]).sum::<f64>() / n as f64).sqrt());
        }
        Series {
            polar,
            per_run: PlotSeries {
                name: name.into(),
                x,
                y,
            },
        }
    }
}

/// Polar plot of the first circle's radial residual and per-run RMS against time, before
/// and after the findings.
pub(crate) fn plots(d: &Design, before: Series, after: Series) -> Vec<PlotData> {
    let mut out = Vec::new();
    if let (Some(run), Some(b), Some(a)) = (first_circle(d), before.polar, after.polar) {
        out.push(PlotData {
            id: "circle_polar".into(),
            title: format!(
                "{} run {}: radial residual",
                d.files[run.plane_idx], run.number
            ),
            x_label: "angle (deg)".into(),
            y_label: "radial residual (µm)".into(),
            kind: PlotKind::Polar,
            series: vec![b, a],
        });
    }
    out.push(PlotData {
        id: "rms_vs_time".into(),
        title: "residual RMS of each run against session time".into(),
        x_label: "time (s)".into(),
        y_label: "RMS (µm)".into(),
        kind: PlotKind::Points,
        series: vec![before.per_run, after.per_run],
    });
    out
}
