//! The contract of a diagnosis's progress reports, shared by the series tests.

/// Checks the reports `seen` (phase, fraction): the first at 0, every fraction in [0, 1]
/// and never below the one before, the last `("done", 1)`, and `phases` present in this
/// order before the last. Returns the index of each phase's first report.
pub fn check(seen: &[(String, f64)], phases: &[&str]) -> Vec<usize> {
    assert_eq!(seen.first().map(|s| s.1), Some(0.0), "{seen:?}");
    assert_eq!(seen.last(), Some(&("done".to_string(), 1.0)), "{seen:?}");
    assert!(seen.windows(2).all(|w| w[1].1 >= w[0].1), "{seen:?}");
    assert!(
        seen.iter().all(|(_, f)| (0.0..=1.0).contains(f)),
        "{seen:?}"
    );
    let mut at: Vec<usize> = phases
        .iter()
        .map(|p| {
            seen.iter()
                .position(|(s, _)| s == p)
                .unwrap_or_else(|| panic!("no phase {p}: {seen:?}"))
        })
        .collect();
    at.push(seen.len() - 1);
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{seen:?}");
    at.pop();
    at
}
