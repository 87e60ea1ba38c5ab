//! The scale of the grid plate per mounting: a plate whose graduation, as mounted for one
//! set of plane files, is longer or shorter than its certificate says — the plate at
//! another temperature than its certificate's (20 °C), or a wrong certificate.
//!
//! **Model** (sign convention of the readings, measured − commanded): the plate of
//! mounting m reads (1 + s_m·10⁻⁶) times the in-plane position in its own frame, so both
//! readings of every run of its files carry
//!
//! du = s_m·u·10⁻³, dv = s_m·v·10⁻³ (µm; u, v in mm, the in-plane position plus the
//! head offset, the plate rotation's point),
//!
//! s_m in ppm, > 0 when the plate reads long (warmer than its certificate for a positive
//! expansion coefficient α: ΔT = s_m/α). Its column ([`columns`]) is that on the rows of
//! mounting m's runs and 0 elsewhere; the per-run zero offsets take the constant part
//! (the plate's origin).
//!
//! **What the data separate.** A machine axis's scale (the linear term of its
//! positioning error, in the rigid model) acts on that axis in every plane that reads
//! it; a plate's scale on both axes of its own mounting only. Over the bipartite graph
//! of mountings and the axes they read, each connected group of mountings has exactly
//! one combination the axes' scales take whole: a scale common to every mounting of the
//! group (+c on each plate, −c on each axis). So a plate scale is a candidate only for a
//! mounting that shares an axis with another mounting, and at most k − 1 of a group of
//! k mountings enter the model ([`open`]): each is reported relative to the group's
//! mountings with no plate scale in the model, and the common part is in the axes'
//! scales (the finding's signature says so). One mounting per axis pair (a single
//! plane, or planes that share no axis) gives no candidate at all. The engine's
//! admission (ΔBIC, a held-out gain on whole runs, a determined σ) does the rest: the
//! greedy search adds first the mounting that explains most, then the next. Before it,
//! two tests of the form (`session::plates`): both readings scaled alike (not one axis's
//! scale, [`half`]), and the scale constant in time over the mounting (each reading's,
//! [`apart`], per quarter of the mounting's time: a warm-up grows, a plate does not).
//!
//! Its rivals: the axes' own scales (linear positioning, common to the planes: in the
//! rigid model), a `thermal_drift` (a scale that changes in time, not from one mounting
//! to the next), a `setup_offset` (a head offset of one group, through the rotations).

use super::{Candidate, Columns};
use crate::axis::Axis;
use crate::diagnosis::design::Design;
use std::collections::BTreeMap;

/// The candidate's effect name (its entry in the effects table:
/// `diagnosis::effects::plate_scale`).
pub const NAME: &str = "plate_scale";

/// An expansion coefficient taken when the session states none, µm/(m·K): a glass or
/// glass-ceramic grid plate's order of magnitude (a steel one's is about 11.5).
pub const TYPICAL_EXPANSION_PPM_PER_K: f64 = 8.0;

/// The session's mountings in their order of appearance, each with the axes its files
/// read.
fn mountings(d: &Design) -> Vec<(String, [bool; 3])> {
    let mut out: Vec<(String, [bool; 3])> = Vec::new();
    for (m, (u, v)) in d.mountings.iter().zip(&d.plane_axes) {
        let i = match out.iter().position(|(n, _)| n == m) {
            Some(i) => i,
            None => {
                out.push((m.clone(), [false; 3]));
                out.len() - 1
            }
        };
        out[i].1[u.index()] = true;
        out[i].1[v.index()] = true;
    }
    out
}

/// The group of mounting `m`: every mounting linked to it through axes they share
/// (itself included; module docs).
fn group_of<'a>(all: &'a [(String, [bool; 3])], m: &str) -> Vec<&'a str> {
    let Some(start) = all.iter().position(|(n, _)| n == m) else {
        return Vec::new();
    };
    let mut axes = all[start].1;
    let mut member = vec![false; all.len()];
    member[start] = true;
    loop {
        let mut grew = false;
        for (i, (_, read)) in all.iter().enumerate() {
            if !member[i] && (0..3).any(|a| read[a] && axes[a]) {
                member[i] = true;
                (0..3).for_each(|a| axes[a] |= read[a]);
                grew = true;
            }
        }
        if !grew {
            break;
        }
    }
    all.iter()
        .zip(member)
        .filter(|(_, m)| *m)
        .map(|((n, _), _)| n.as_str())
        .collect()
}

/// The groups of two or more mountings linked through the axes they share (module
/// docs), each in the order of appearance.
pub fn groups(d: &Design) -> Vec<Vec<String>> {
    let all = mountings(d);
    let mut out: Vec<Vec<String>> = Vec::new();
    for (m, _) in &all {
        if out.iter().any(|g| g.contains(m)) {
            continue;
        }
        let g = group_of(&all, m);
        if g.len() >= 2 {
            out.push(g.into_iter().map(str::to_string).collect());
        }
    }
    out
}

/// The candidate of mounting `m`.
pub fn candidate(m: &str) -> Candidate {
    Candidate {
        effect: NAME,
        axis: None,
        direction: None,
        group: None,
        order: 0,
        width_s: 0.0,
        lost_motion_um: 0.0,
        mounting: Some(m.to_string()),
        parent: None,
    }
}

/// One axis's half of mounting `m`'s candidate: the scale of the reading along `axis`
/// alone on the mounting's runs — an axis whose scale changed between mountings, as a
/// warm-up of that axis reads, not a plate (its form test, `session::plates`). Never
/// offered as a finding.
pub fn half(m: &str, axis: Axis) -> Candidate {
    Candidate {
        axis: Some(axis),
        ..candidate(m)
    }
}

/// The axes mounting `m`'s files read, in axis order.
pub fn axes_read(d: &Design, m: &str) -> Vec<Axis> {
    mountings(d)
        .into_iter()
        .find(|(n, _)| n == m)
        .map(|(_, read)| Axis::ALL.into_iter().filter(|a| read[a.index()]).collect())
        .unwrap_or_default()
}

/// The mounting whose scale a group's others are reported against: the median of the
/// group's `values` (ppm, 0 for a mounting with no plate scale in the model; the lower
/// middle one of an even group). The scales the data determine are the differences
/// between mountings; against the median, a plate that most of its mountings agree on
/// reads true and the fewest, smallest scales are reported (the least sum of |s|).
pub fn median_reference(values: &[(String, f64)]) -> Option<&str> {
    let mut sorted: Vec<&(String, f64)> = values.iter().collect();
    sorted.sort_by(|a, b| a.1.total_cmp(&b.1));
    sorted
        .get(sorted.len().saturating_sub(1) / 2)
        .map(|(m, _)| m.as_str())
}

/// The candidates: one per mounting that shares an axis with another (module docs).
pub fn candidates(d: &Design) -> Vec<Candidate> {
    let all = mountings(d);
    all.iter()
        .filter(|(m, _)| group_of(&all, m).len() >= 2)
        .map(|(m, _)| candidate(m))
        .collect()
}

/// Whether mounting `m`'s plate scale may join a model that holds those of `held`: not
/// there yet, and fewer than k − 1 of its group of k mountings in it (module docs).
pub fn open(d: &Design, held: &[String], m: &str) -> bool {
    let all = mountings(d);
    let group = group_of(&all, m);
    let in_model = group
        .iter()
        .filter(|g| held.iter().any(|h| h == *g))
        .count();
    !held.iter().any(|h| h == m) && group.len() >= 2 && in_model + 1 < group.len()
}

/// The column of candidate `c` (module docs): its coefficient is s, ppm.
pub(crate) fn columns<'a>(d: &'a Design, c: &Candidate) -> Columns<'a> {
    let Some(m) = c.mounting.clone() else {
        return Columns::new(Vec::new(), Vec::new(), |_, _, _| {});
    };
    let reading = reading_on(d, &m);
    // A half (`half`) reads along its axis only.
    let only = c.axis;
    Columns::new(vec!["scale_ppm".into()], vec![None], move |s, read, o| {
        o[0] = if only.is_none_or(|a| a == read) {
            reading(s, read)
        } else {
            0.0
        };
    })
    .only_on(runs_of(d, &m))
}

/// Per run of the design: whether it is of mounting `m`'s files (where its columns are
/// not 0).
fn runs_of(d: &Design, m: &str) -> Vec<bool> {
    d.runs
        .iter()
        .map(|r| d.mountings[r.plane_idx] == m)
        .collect()
}

/// The column of a scale of mounting `m`'s plate at a sample read along an axis: the head
/// position along it, (q + head offset)·10⁻³ (a scale in ppm, µm), on the mounting's runs;
/// 0 on the others.
fn reading_on<'a>(d: &'a Design, m: &str) -> impl Fn(usize, Axis) -> f64 + 'a {
    let on = runs_of(d, m);
    move |s, read| {
        let g = d.fields.run(s);
        let (run, i) = (&d.runs[g], read.index());
        if on[g] {
            (d.fields.q_mm[i][s] + run.head_mm[i]) * 1e-3
        } else {
            0.0
        }
    }
}

/// Mounting `m`'s two halves ([`half`]) side by side: a scale per reading axis of its
/// runs, one column each in `axes`' order (the constancy test's form, `session::plates`).
pub(crate) fn apart<'a>(d: &'a Design, m: &str, axes: &[Axis]) -> Columns<'a> {
    let reading = reading_on(d, m);
    let axes = axes.to_vec();
    let names = axes.iter().map(|a| format!("scale_ppm_{a}")).collect();
    let read_by = axes.iter().map(|&a| Some(a)).collect();
    Columns::new(names, read_by, move |s, read, o| {
        for (v, a) in o.iter_mut().zip(&axes) {
            *v = if *a == read { reading(s, read) } else { 0.0 };
        }
    })
    .only_on(runs_of(d, m))
}

/// The mountings of `m`'s group with no plate scale in the model `held` (the reference
/// its scale is reported against), and the plane of each of `m`'s files.
fn reference(d: &Design, held: &[String], m: &str) -> (Vec<String>, Vec<String>) {
    let all = mountings(d);
    let refs = group_of(&all, m)
        .into_iter()
        .filter(|g| *g != m && !held.iter().any(|h| h == g))
        .map(|g| format!("`{g}`"))
        .collect();
    let mut planes: Vec<String> = d
        .mountings
        .iter()
        .zip(&d.planes)
        .filter(|(x, _)| *x == m)
        .map(|(_, p)| p.to_string())
        .collect();
    planes.dedup();
    (refs, planes)
}

/// The finding's signature: the mounting, its plane(s), the reference and what the
/// scale means (module docs): the plate's temperature against its certificate's at the
/// session's expansion coefficient (or at [`TYPICAL_EXPANSION_PPM_PER_K`], said so), or
/// a wrong certificate.
pub fn signature(d: &Design, held: &[String], m: &str, scale_ppm: Option<f64>) -> String {
    let (refs, planes) = reference(d, held, m);
    let mut s = format!(
        "both readings of the plate of mounting `{m}` (plane {}) scaled alike, relative to mounting(s) {} (a scale common to every mounting is not told from the axes' scales: it is in their linear positioning)",
        planes.join(", "),
        refs.join(", ")
    );
    if let Some(k) = scale_ppm {
        let (alpha, stated) = match d.plate_expansion_ppm_per_k {
            Some(a) if a.abs() > 0.0 => (a, true),
            _ => (TYPICAL_EXPANSION_PPM_PER_K, false),
        };
        let dt = k / alpha;
        let side = if dt >= 0.0 { "warmer" } else { "colder" };
        s += &format!(
            ": the plate ≈ {:.1} K {side} than its certificate for a coefficient of {alpha} ppm/K{}, or a wrong plate certificate",
            dt.abs(),
            if stated {
                " (the session's)"
            } else {
                " (the session states none)"
            }
        );
    }
    s
}

/// Adds the plate's temperature against its certificate's, ΔT = s/α with its σ, to the
/// parameters of an accepted plate scale when the session states the plate's expansion
/// coefficient α (module docs).
pub(crate) fn parameters(p: &mut BTreeMap<String, f64>, d: &Design) {
    let (Some(alpha), Some(&s), Some(&sd)) = (
        d.plate_expansion_ppm_per_k.filter(|a| a.abs() > 0.0),
        p.get("scale_ppm"),
        p.get("std_scale_ppm"),
    ) else {
        return;
    };
    p.insert("temperature_offset_k".into(), s / alpha);
    p.insert("std_temperature_offset_k".into(), sd / alpha.abs());
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnosis::design;
    use crate::simulate::seed_session;

    fn design_of(session: &crate::session::Session) -> Design {
        design::build(session, &Default::default(), 3).expect("a design")
    }

    fn names(c: &[Candidate]) -> Vec<String> {
        c.iter().filter_map(|c| c.mounting.clone()).collect()
    }

    #[test]
    fn the_table_entry_names_the_scale_as_principal() {
        let spec = crate::diagnosis::effects::spec(NAME).expect("in the table");
        assert!(spec.params.iter().any(|p| p.name == spec.principal[0]));
    }

    /// Three planes, one mounting each: one candidate per mounting, at most two of the
    /// three in a model (the common scale is the axes').
    #[test]
    fn three_mountings_leave_their_common_scale_to_the_axes() {
        let session = seed_session(3);
        let d = design_of(&session);
        let mounts: Vec<String> = session.planes.iter().map(|p| p.mounting.clone()).collect();
        assert_eq!(mounts.len(), 3);
        assert_eq!(names(&candidates(&d)), mounts);
        assert_eq!(groups(&d), vec![mounts.clone()]);
        assert!(open(&d, &[], &mounts[0]));
        assert!(open(&d, &mounts[..1], &mounts[1]));
        assert!(!open(&d, &mounts[..1], &mounts[0]), "once");
        assert!(
            !open(&d, &mounts[..2], &mounts[2]),
            "the third is the common scale"
        );
    }

    /// One mounting per axis pair: no candidate (its scale is the two axes' scales).
    #[test]
    fn one_mounting_is_no_candidate() {
        let mut session = seed_session(3);
        session.planes.truncate(1);
        assert!(candidates(&design_of(&session)).is_empty());
        // Two files of one plane under one mounting: still one plate.
        let mut twice = seed_session(3);
        twice.planes.truncate(1);
        let mut again = twice.planes[0].clone();
        again.file = "again.csv".into();
        twice.planes.push(again.clone());
        assert!(candidates(&design_of(&twice)).is_empty());
        // Re-mounted (another mounting of the same plane): a contrast, one of the two.
        again.mounting = format!("{}-2", again.mounting);
        twice.planes[1] = again;
        let d = design_of(&twice);
        let c = names(&candidates(&d));
        assert_eq!(c.len(), 2);
        assert!(open(&d, &[], &c[1]));
        assert!(!open(&d, &c[..1], &c[1]));
    }

    /// The column is (u, v)·10⁻³ on both readings of the mounting's runs only.
    #[test]
    fn the_column_scales_both_readings_of_its_mounting() {
        let session = seed_session(3);
        let d = design_of(&session);
        let m = session.planes[1].mounting.clone();
        let cols = columns(&d, &candidate(&m));
        let mut o = [0.0];
        for row in 0..d.rows() {
            let s = row / 2;
            let run = &d.runs[d.fields.run(s)];
            cols.at(&d, row, &mut o);
            let read = d.row_axis(row).index();
            let want = if run.plane_idx == 1 {
                (d.fields.q_mm[read][s] + run.head_mm[read]) * 1e-3
            } else {
                0.0
            };
            assert_eq!(o[0], want);
        }
    }

    /// A half of the candidate (its form test) reads its one axis on the mounting's
    /// runs: the two halves add up to the plate's column, and each mounting reads its
    /// plane's two axes.
    #[test]
    fn the_halves_add_up_to_the_plate() {
        let session = seed_session(3);
        let d = design_of(&session);
        let m = session.planes[0].mounting.clone();
        let axes = axes_read(&d, &m);
        assert_eq!(axes.len(), 2);
        let whole = columns(&d, &candidate(&m));
        let halves: Vec<Columns> = axes.iter().map(|&a| columns(&d, &half(&m, a))).collect();
        let (mut o, mut h) = ([0.0], [0.0]);
        for row in 0..d.rows() {
            whole.at(&d, row, &mut o);
            let mut sum = 0.0;
            for (a, c) in axes.iter().zip(&halves) {
                c.at(&d, row, &mut h);
                if d.row_axis(row) != *a {
                    assert_eq!(h[0], 0.0);
                }
                sum += h[0];
            }
            assert_eq!(sum, o[0]);
        }
    }

    /// The mounting's scales apart (the constancy test's form) are its two halves side
    /// by side.
    #[test]
    fn apart_is_the_halves_side_by_side() {
        let session = seed_session(3);
        let d = design_of(&session);
        let m = session.planes[2].mounting.clone();
        let axes = axes_read(&d, &m);
        let both = apart(&d, &m, &axes);
        assert_eq!(both.len(), 2);
        let halves: Vec<Columns> = axes.iter().map(|&a| columns(&d, &half(&m, a))).collect();
        let (mut o, mut h) = ([0.0; 2], [0.0]);
        for row in 0..d.rows() {
            both.at(&d, row, &mut o);
            for (j, c) in halves.iter().enumerate() {
                c.at(&d, row, &mut h);
                assert_eq!(o[j], h[0]);
            }
        }
    }

    #[test]
    fn the_median_mounting_is_the_reference() {
        let v = |a: f64, b: f64, c: f64| {
            vec![("xy".to_string(), a), ("xz".into(), b), ("yz".into(), c)]
        };
        assert_eq!(median_reference(&v(-6.0, -14.0, 0.0)), Some("xy"));
        assert_eq!(
            median_reference(&v(10.0, 0.0, 0.0)).map(|m| m != "xy"),
            Some(true)
        );
        assert_eq!(median_reference(&v(0.0, 8.0, 14.0)), Some("xz"));
    }
}
