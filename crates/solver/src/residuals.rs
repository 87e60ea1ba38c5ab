//! Residuals of a session fit summarised by file and test: where the model explains the
//! readings and where it does not.

use crate::session::Session;
use serde::{Deserialize, Serialize};

/// RMS residual of the runs of one test kind in one plane file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct ResidualSummary {
    pub file: String,
    /// `line_X`, `circle_ccw`, ... (the run's test kind).
    pub test: String,
    pub runs: usize,
    pub samples: usize,
    /// √(Σ (r_u² + r_v²) / 2N) over the N samples: per reading component, µm.
    pub rms_um: f64,
}

/// Summarises residuals (reading − model, [plane][run][sample] = (u, v), µm) by file and
/// test, in session order.
pub fn by_file_and_test(
    session: &Session,
    residuals: &[Vec<Vec<[f64; 2]>>],
) -> Vec<ResidualSummary> {
    let mut out: Vec<(ResidualSummary, f64)> = vec![];
    for (rec, res) in session.planes.iter().zip(residuals) {
        for (run, r) in rec.runs.iter().zip(res) {
            let test = run.test_kind(rec.plane).name();
            let ss: f64 = r.iter().map(|v| v[0] * v[0] + v[1] * v[1]).sum();
            let i = match out
                .iter()
                .position(|(s, _)| s.file == rec.file && s.test == test)
            {
                Some(i) => i,
                None => {
                    out.push((
                        ResidualSummary {
                            file: rec.file.clone(),
                            test: test.into(),
                            runs: 0,
                            samples: 0,
                            rms_um: 0.0,
                        },
                        0.0,
                    ));
                    out.len() - 1
                }
            };
            out[i].0.runs += 1;
            out[i].0.samples += r.len();
            out[i].1 += ss;
        }
    }
    out.into_iter()
        .map(|(mut s, ss)| {
            s.rms_um = (ss / (2 * s.samples.max(1)) as f64).sqrt();
            s
        })
        .collect()
}
