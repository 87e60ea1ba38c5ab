use mtcal_solver::cradle::*;

#[test]
fn scratch_print() {
    for compliant in [false, true] {
        let mut sim = CradleSimulation::example(compliant, 1);
        sim.noise_um = 0.0;
        let pts = simulate_cradle(&sim);
        let t = std::time::Instant::now();
        let r = check_cradle(&pts, &CradleOptions::default()).unwrap();
        eprintln!("elapsed {:?}", t.elapsed());
        for p in &r.poses {
            eprintln!(
                "{:6.1} pt {:8.1} {:?}  ph {:8.1} {:?} pool {:?} dev {:.1}",
                p.a_deg,
                p.rotation_point.norm_urad,
                p.rotation_point.vector_urad.map(|v| v.round()),
                p.rotation_phase.norm_urad,
                p.rotation_phase.vector_urad.map(|v| v.round()),
                p.rotation_pooled.vector_urad.map(|v| v.round()),
                p.angle_deviation_urad
            );
        }
        eprintln!(
            "{}",
            serde_json::to_string_pretty(&r.rotation_model).unwrap()
        );
        eprintln!(
            "{}",
            serde_json::to_string_pretty(&r.location_errors).unwrap()
        );
        eprintln!(
            "{}",
            serde_json::to_string_pretty(&r.kinematics.rigid).unwrap()
        );
        eprintln!(
            "{}",
            serde_json::to_string_pretty(&r.kinematics.compliant).unwrap()
        );
        eprintln!(
            "{}",
            serde_json::to_string_pretty(&r.kinematics.compliance).unwrap()
        );
        eprintln!(
            "{} {}",
            r.compensation.before_rms_um, r.compensation.after_rms_um
        );
    }
}
