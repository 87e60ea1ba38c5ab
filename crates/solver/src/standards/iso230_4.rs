//! ISO 230-4:2005 figures of circular tests (two linear axes contouring a circle), from
//! the circle runs of a grid-encoder session.
//!
//! A circle run in plane (u, v): commanded positions q (mm) and deviations δ = (du, dv)
//! (µm). The **nominal path** is the least-squares (Kåsa) circle through the commanded
//! positions: centre c₀, radius R₀ (so the diameter reported is 2R₀). The **actual path**
//! is q + δ. Per sample, the radial deviation from the nominal radius about c₀ is
//! ρ = |q + δ − c₀| − R₀ (µm); the samples taken while the command advances (the end
//! dwell dropped) are averaged in 1° bins of the angle θ = atan2(v − c₀v, u − c₀u),
//! measured from +u toward +v, so that every part of the circle weighs the same.
//!
//! **Least-squares circle (LSC)** of the actual path: the linearised fit
//! ρ̄(θ) ≈ a + b cos θ + c sin θ over the bins (error O(δ²/R₀)), solved by SVD; its centre
//! is c₀ + (b, c)·10⁻³ mm and its radius R₀ + a·10⁻³ mm. About that centre the radial
//! deviation from the nominal radius is e(θ) = ρ̄(θ) − b cos θ − c sin θ.
//!
//! | figure | formula |
//! |---|---|
//! | circular deviation G (cw, ccw) | max e − min e of the path |
//! | mean radial deviation | a (LSC radius − nominal radius) |
//! | radial deviation F | F_max = max e, F_min = min e (actual − nominal radius, LSC centre) |
//! | bidirectional circular deviation G(b) | max − min of e over both paths |
//! | circular hysteresis H | max over common bins \|e_cw(θ) − e_ccw(θ)\| |
//! | bidirectional mean radial deviation, F(b) | mean of the two a; max and min of e over both |
//!
//! A grid encoder's zero is set per run, so each path is referred to **its own** LSC
//! centre before the two are compared (a shared centre would turn the two runs' zero
//! offsets into hysteresis). Its radius is traceable (the plate's graduation), so the
//! mean radial deviation and F are reported.
//!
//! **Uncertainty**: noise only. The reading noise σ̂ of a run is estimated from successive
//! samples, σ̂² = Σ (ρ_{k+1} − ρ_k)² / (2(N − 1)) (insensitive to the smooth error
//! pattern); a bin mean has u = σ̂/√n_bin, a range the root-sum-square of its two ends,
//! the mean radial deviation σ̂/√N. The plate's calibration is not included.

use crate::axis::Plane;
use crate::session::{Run, Session, kasa_circle};
use crate::standards::{ScalarFigure, extremes, nearest_first};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::PI;

/// Number of angle bins over a full turn (1° each).
pub const BINS: usize = 360;

/// A circle run reduced to its binned radial deviations (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CirclePath {
    /// `ccw` or `cw`.
    pub ccw: bool,
    /// Nominal centre c₀ (u, v) and radius R₀, mm.
    pub centre_mm: [f64; 2],
    pub radius_mm: f64,
    /// Angle of the first sample, degrees in [0, 360).
    pub start_angle_deg: f64,
    /// Angle swept, degrees (positive).
    pub sweep_deg: f64,
    /// Median feed along the path, mm/min.
    pub feed_mm_min: f64,
    /// Bin centre angles (degrees), bins with samples only.
    pub angle_deg: Vec<f64>,
    /// Mean ρ per bin, µm (about c₀, from R₀).
    pub rho_um: Vec<f64>,
    /// Samples per bin.
    pub count: Vec<usize>,
    /// Reading noise σ̂ from successive samples, µm.
    pub sigma_um: f64,
    /// Samples used.
    pub samples: usize,
    /// The least-squares circle of the bins, computed once ([`CirclePath::lsc`]).
    lsc: Option<Lsc>,
}

/// The least-squares circle of a path (module docs): a, b, c (µm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lsc {
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

/// The commanded side of a circle run (module docs): the samples taken while the command
/// advances, the nominal circle c₀, R₀ through them, each sample's angle θ and bin, the
/// sweep and the feed. It does not depend on the readings, so a run's measured path and
/// the fitted model's path of it are reduced from one geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct CircleGeometry {
    /// The plane's (u, v) axis indices.
    axes: (usize, usize),
    /// Indices of the samples kept.
    keep: Vec<u32>,
    centre_mm: [f64; 2],
    radius_mm: f64,
    /// Bin of each sample kept.
    bin: Vec<u16>,
    ccw: bool,
    start_angle_deg: f64,
    sweep_deg: f64,
    feed_mm_min: f64,
}

impl CircleGeometry {
    /// The geometry of one circle run in `plane`; `None` for fewer than 8 moving samples,
    /// no circle, or a run of more than `u32::MAX` samples (indices are held as `u32`).
    pub fn of(run: &Run, plane: Plane) -> Option<CircleGeometry> {
        let (ua, va) = plane.axes();
        let (iu, iv) = (ua.index(), va.index());
        // Samples taken while the command advances (drop dwells and repeats).
        let mut keep: Vec<usize> = vec![];
        for (k, p) in run.pos_mm.iter().enumerate() {
            if keep.last().is_none_or(|&l| {
                let q = run.pos_mm[l];
                p[iu] != q[iu] || p[iv] != q[iv]
            }) {
                keep.push(k);
            }
        }
        if keep.len() < 8 {
            return None;
        }
        let uv: Vec<(f64, f64)> = keep
            .iter()
            .map(|&k| (run.pos_mm[k][iu], run.pos_mm[k][iv]))
            .collect();
        let (cu, cv, r0) = kasa_circle(&uv)?;
        let theta: Vec<f64> = uv
            .iter()
            .map(|&(u, v)| (v - cv).atan2(u - cu).rem_euclid(2.0 * PI))
            .collect();
        let bin = theta
            .iter()
            .map(|th| ((th / (2.0 * PI) * BINS as f64) as u16).min(BINS as u16 - 1))
            .collect();
        let sweep: f64 = theta
            .windows(2)
            .map(|w| {
                let d = w[1] - w[0];
                d - 2.0 * PI * ((d + PI) / (2.0 * PI)).floor()
            })
            .sum();
        let mut speeds: Vec<f64> = keep
            .windows(2)
            .filter_map(|w| {
                let (a, b) = (run.pos_mm[w[0]], run.pos_mm[w[1]]);
                let dt = run.t_s[w[1]] - run.t_s[w[0]];
                (dt > 0.0).then(|| 60.0 * (b[iu] - a[iu]).hypot(b[iv] - a[iv]) / dt)
            })
            .collect();
        let feed_mm_min = match speeds.len() {
            0 => 0.0,
            n => *speeds.select_nth_unstable_by(n / 2, f64::total_cmp).1,
        };
        Some(CircleGeometry {
            centre_mm: [cu, cv],
            radius_mm: r0,
            bin,
            ccw: sweep > 0.0,
            // (θ just below 2π from rounding is 0.)
            start_angle_deg: {
                let a = theta[0].to_degrees();
                if a > 360.0 - 1e-9 { 0.0 } else { a }
            },
            sweep_deg: sweep.abs().to_degrees(),
            feed_mm_min,
            axes: (iu, iv),
            keep: keep
                .into_iter()
                .map(|k| u32::try_from(k).ok())
                .collect::<Option<_>>()?,
        })
    }

    /// Reduces the deviations `du`, `dv` (µm, per sample of `run`, the run this geometry
    /// is of: the readings, or a model's prediction of them) along this geometry.
    pub fn path(&self, run: &Run, du: &[f64], dv: &[f64]) -> CirclePath {
        let [cu, cv] = self.centre_mm;
        let (iu, iv) = self.axes;
        let r0 = self.radius_mm;
        let mut sum = vec![0.0; BINS];
        let mut count = vec![0usize; BINS];
        let mut rho = Vec::with_capacity(self.keep.len());
        for (&k, &bin) in self.keep.iter().zip(&self.bin) {
            let (k, bin) = (k as usize, bin as usize);
            let (u, v) = (run.pos_mm[k][iu], run.pos_mm[k][iv]);
            let (au, av) = (u + 1e-3 * du[k] - cu, v + 1e-3 * dv[k] - cv);
            let r = 1e3 * (au.hypot(av) - r0);
            sum[bin] += r;
            count[bin] += 1;
            rho.push(r);
        }
        let n = rho.len();
        let sigma = (rho.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>()
            / (2.0 * (n - 1) as f64))
            .sqrt();
        let (mut angle_deg, mut rho_um, mut cnt) = (vec![], vec![], vec![]);
        for b in 0..BINS {
            if count[b] > 0 {
                angle_deg.push((b as f64 + 0.5) * 360.0 / BINS as f64);
                rho_um.push(sum[b] / count[b] as f64);
                cnt.push(count[b]);
            }
        }
        let lsc = least_squares_circle(&angle_deg, &rho_um);
        CirclePath {
            ccw: self.ccw,
            centre_mm: self.centre_mm,
            radius_mm: r0,
            start_angle_deg: self.start_angle_deg,
            sweep_deg: self.sweep_deg,
            feed_mm_min: self.feed_mm_min,
            angle_deg,
            rho_um,
            count: cnt,
            sigma_um: sigma,
            samples: n,
            lsc,
        }
    }
}

/// The least-squares circle (module docs) of bin means `rho_um` at `angle_deg`: the
/// linearised fit a + b cos θ + c sin θ, solved by SVD; `None` with fewer than 3 bins.
fn least_squares_circle(angle_deg: &[f64], rho_um: &[f64]) -> Option<Lsc> {
    let m = angle_deg.len();
    if m < 3 {
        return None;
    }
    let a = DMatrix::from_fn(m, 3, |i, j| {
        let th = angle_deg[i].to_radians();
        [1.0, th.cos(), th.sin()][j]
    });
    let y = DVector::from_column_slice(rho_um);
    let x = a.svd(true, true).solve(&y, 1e-12).ok()?;
    Some(Lsc {
        a: x[0],
        b: x[1],
        c: x[2],
    })
}

impl CirclePath {
    /// Reduces one circle run: `du`, `dv` are the deviations per sample (the readings, or a
    /// model's prediction of them). `None` for fewer than 8 moving samples or no circle.
    pub fn of(run: &Run, plane: Plane, du: &[f64], dv: &[f64]) -> Option<CirclePath> {
        Some(CircleGeometry::of(run, plane)?.path(run, du, dv))
    }

    /// The least-squares circle (module docs); `None` with fewer than 3 bins.
    pub fn lsc(&self) -> Option<Lsc> {
        self.lsc
    }

    /// e(θ) per bin: radial deviation from the nominal radius about the LSC centre, µm.
    pub fn radial_about(&self, l: &Lsc) -> Vec<f64> {
        self.angle_deg
            .iter()
            .zip(&self.rho_um)
            .map(|(t, r)| {
                let th = t.to_radians();
                r - l.b * th.cos() - l.c * th.sin()
            })
            .collect()
    }

    /// u of bin i's mean.
    fn u_bin(&self, i: usize) -> f64 {
        self.sigma_um / (self.count[i] as f64).sqrt()
    }

    fn direction(&self) -> &'static str {
        if self.ccw { "ccw" } else { "cw" }
    }
}

/// Figures of one circle (one direction), µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CircleFigures {
    /// `cw` or `ccw` (counter-clockwise: from +u toward +v).
    pub direction: String,
    /// Run number in its file.
    pub run: i64,
    pub start_angle_deg: f64,
    pub sweep_deg: f64,
    pub feed_mm_min: f64,
    /// LSC centre (u, v), mm; its offset from the commanded centre includes the run's
    /// encoder zero, so it is not a machine error.
    pub centre_mm: [f64; 2],
    /// G
    #[serde(rename = "G_um")]
    pub g_um: f64,
    /// LSC radius − nominal radius
    pub mean_radial_um: f64,
    #[serde(rename = "F_max_um")]
    pub f_max_um: f64,
    #[serde(rename = "F_min_um")]
    pub f_min_um: f64,
    /// Reading noise σ̂ of the run, µm.
    pub noise_um: f64,
    pub samples: usize,
    /// Standard uncertainty of each figure, keyed by name, µm.
    pub u: BTreeMap<String, f64>,
}

/// Bidirectional figures (both directions of one plane), µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Bidirectional {
    /// G(b)
    #[serde(rename = "G_um")]
    pub g_um: f64,
    /// H
    #[serde(rename = "H_um")]
    pub h_um: f64,
    pub mean_radial_um: f64,
    #[serde(rename = "F_max_um")]
    pub f_max_um: f64,
    #[serde(rename = "F_min_um")]
    pub f_min_um: f64,
    pub u: BTreeMap<String, f64>,
}

/// ISO 230-4 figures of one plane: the items to report and the figures per direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct Iso2304 {
    pub plane: Plane,
    pub file: String,
    pub head_offset_mm: [f64; 3],
    /// Nominal diameter 2R₀, mm.
    pub diameter_mm: f64,
    /// Whether the radius is traceable (true for a grid plate): the mean radial
    /// deviation and F are meaningful.
    pub traceable_radius: bool,
    /// Per direction (`cw`, `ccw`), in that order when both exist.
    pub directions: Vec<CircleFigures>,
    /// When both directions exist.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bidirectional: Option<Bidirectional>,
    pub notes: Vec<String>,
}

/// Figures of one path (module table).
pub fn circle_figures(path: &CirclePath, run: i64) -> Option<CircleFigures> {
    let l = path.lsc()?;
    let e = path.radial_about(&l);
    let (hi, lo) = extremes(e.iter().enumerate().map(|(i, &v)| (v, path.u_bin(i))));
    let u_mean = path.sigma_um / (path.samples as f64).sqrt();
    let u = BTreeMap::from([
        ("G_um".to_string(), hi.1.hypot(lo.1)),
        ("mean_radial_um".to_string(), u_mean),
        ("F_max_um".to_string(), hi.1),
        ("F_min_um".to_string(), lo.1),
    ]);
    Some(CircleFigures {
        direction: path.direction().into(),
        run,
        start_angle_deg: path.start_angle_deg,
        sweep_deg: path.sweep_deg,
        feed_mm_min: path.feed_mm_min,
        centre_mm: [
            path.centre_mm[0] + 1e-3 * l.b,
            path.centre_mm[1] + 1e-3 * l.c,
        ],
        g_um: hi.0 - lo.0,
        mean_radial_um: l.a,
        f_max_um: hi.0,
        f_min_um: lo.0,
        noise_um: path.sigma_um,
        samples: path.samples,
        u,
    })
}

/// Bidirectional figures of a cw and a ccw path (module table), each about its own LSC.
pub fn bidirectional(cw: &CirclePath, ccw: &CirclePath) -> Option<Bidirectional> {
    let (lw, lc) = (cw.lsc()?, ccw.lsc()?);
    let (ew, ec) = (cw.radial_about(&lw), ccw.radial_about(&lc));
    let both = ew
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, cw.u_bin(i)))
        .chain(ec.iter().enumerate().map(|(i, &v)| (v, ccw.u_bin(i))));
    let (hi, lo) = extremes(both);
    // H over the bins both paths cover.
    let mut h = (0.0f64, 0.0f64);
    for (i, a) in cw.angle_deg.iter().enumerate() {
        if let Some(j) = ccw.angle_deg.iter().position(|b| (a - b).abs() < 1e-9) {
            let d = (ew[i] - ec[j]).abs();
            if d > h.0 {
                h = (d, cw.u_bin(i).hypot(ccw.u_bin(j)));
            }
        }
    }
    let u_mean = 0.5
        * (cw.sigma_um.powi(2) / cw.samples as f64 + ccw.sigma_um.powi(2) / ccw.samples as f64)
            .sqrt();
    Some(Bidirectional {
        g_um: hi.0 - lo.0,
        h_um: h.0,
        mean_radial_um: 0.5 * (lw.a + lc.a),
        f_max_um: hi.0,
        f_min_um: lo.0,
        u: BTreeMap::from([
            ("G_um".to_string(), hi.1.hypot(lo.1)),
            ("H_um".to_string(), h.1),
            ("mean_radial_um".to_string(), u_mean),
            ("F_max_um".to_string(), hi.1),
            ("F_min_um".to_string(), lo.1),
        ]),
    })
}

/// The standard's symbol and name of a figure ([`DIRECTION_FIGURES`],
/// [`BIDIRECTIONAL_FIGURES`] names).
pub fn figure_name(figure: &str) -> Option<(&'static str, &'static str)> {
    Some(match figure {
        "G_um" => ("G", "circular deviation"),
        "H_um" => ("H", "circular hysteresis"),
        "mean_radial_um" => (
            "mean radial deviation",
            "least-squares radius − nominal radius",
        ),
        "F_max_um" => ("F max", "radial deviation, largest"),
        "F_min_um" => ("F min", "radial deviation, smallest"),
        _ => return None,
    })
}

/// Names of the figures per direction and bidirectionally.
pub const DIRECTION_FIGURES: [&str; 4] = ["G_um", "mean_radial_um", "F_max_um", "F_min_um"];
pub const BIDIRECTIONAL_FIGURES: [&str; 5] =
    ["G_um", "H_um", "mean_radial_um", "F_max_um", "F_min_um"];

impl Iso2304 {
    /// The figures as stored scalars, named `iso230_4.<plane>.<cw|ccw|bi>.<figure>`.
    pub fn scalar_figures(&self) -> Vec<ScalarFigure> {
        let mut out = vec![];
        let plane = format!("{:?}", self.plane);
        for d in &self.directions {
            let vals = [d.g_um, d.mean_radial_um, d.f_max_um, d.f_min_um];
            for (name, value) in DIRECTION_FIGURES.iter().zip(vals) {
                out.push(ScalarFigure {
                    name: format!("iso230_4.{plane}.{}.{name}", d.direction),
                    value,
                    u: d.u.get(*name).copied(),
                });
            }
        }
        if let Some(b) = &self.bidirectional {
            let vals = [b.g_um, b.h_um, b.mean_radial_um, b.f_max_um, b.f_min_um];
            for (name, value) in BIDIRECTIONAL_FIGURES.iter().zip(vals) {
                out.push(ScalarFigure {
                    name: format!("iso230_4.{plane}.bi.{name}"),
                    value,
                    u: b.u.get(*name).copied(),
                });
            }
        }
        out
    }
}

/// A circle run of a session: where it is, its geometry and its measured path.
#[derive(Debug, Clone)]
pub struct CircleRun {
    /// Index of the plane file in the session.
    pub plane: usize,
    /// Index of the run in its plane file.
    pub run: usize,
    pub geometry: CircleGeometry,
    /// The readings' path.
    pub path: CirclePath,
}

/// The circle runs of every plane file, in session order.
pub fn circle_runs(session: &Session) -> Vec<CircleRun> {
    let mut out = vec![];
    for (p, rec) in session.planes.iter().enumerate() {
        for (r, run) in rec.runs.iter().enumerate() {
            if !run.test_kind(rec.plane).is_circle() {
                continue;
            }
            if let Some(geometry) = CircleGeometry::of(run, rec.plane) {
                let path = geometry.path(run, &run.du_um, &run.dv_um);
                out.push(CircleRun {
                    plane: p,
                    run: r,
                    geometry,
                    path,
                });
            }
        }
    }
    out
}

/// ISO 230-4 figures per plane from the circle runs of a session: from the plane file
/// nearest the tool reference point (smallest |t|; the first in the session on ties)
/// among those with circle runs, its first cw and first ccw run.
pub fn from_session(session: &Session) -> Vec<Iso2304> {
    from_circle_runs(session, &circle_runs(session))
}

/// [`from_session`] from the session's circle runs (as [`circle_runs`] gives them).
pub fn from_circle_runs(session: &Session, circles: &[CircleRun]) -> Vec<Iso2304> {
    let paths: Vec<(usize, usize, &CirclePath)> =
        circles.iter().map(|c| (c.plane, c.run, &c.path)).collect();
    let mut out = vec![];
    for plane in Plane::ALL {
        let mut files: Vec<usize> = paths
            .iter()
            .filter(|(p, _, _)| session.planes[*p].plane == plane)
            .map(|(p, _, _)| *p)
            .collect();
        files.dedup();
        nearest_first(session, &mut files);
        let Some(&file) = files.first() else {
            continue;
        };
        let rec = &session.planes[file];
        let of_dir = |ccw: bool| {
            paths
                .iter()
                .find(|(p, _, c)| *p == file && c.ccw == ccw)
                .map(|(_, r, c)| (rec.runs[*r].number, c))
        };
        let (cw, ccw) = (of_dir(false), of_dir(true));
        let mut notes = vec![];
        let mut directions = vec![];
        for (run, path) in [cw, ccw].into_iter().flatten() {
            if path.sweep_deg < 359.0 {
                notes.push(format!(
                    "run {run} ({}) sweeps {:.1}°, not a full circle: its figures cover that arc",
                    path.direction(),
                    path.sweep_deg
                ));
            }
            directions.extend(circle_figures(path, run));
        }
        let radius = cw.or(ccw).map_or(0.0, |(_, c)| c.radius_mm);
        notes.push(
            "the encoder's zero is set per run, so each path is referred to its own least-squares centre".into(),
        );
        if plane == Plane::XZ {
            notes.push(
                "in the XZ plane ccw turns from +X toward +Z, the opposite of G18's sense".into(),
            );
        }
        let others: Vec<&str> = files[1..]
            .iter()
            .map(|&p| session.planes[p].file.as_str())
            .collect();
        if !others.is_empty() {
            notes.push(format!(
                "other files with circles in {plane:?}, not evaluated here: {}",
                others.join(", ")
            ));
        }
        out.push(Iso2304 {
            plane,
            file: rec.file.clone(),
            head_offset_mm: rec.head_offset_mm,
            diameter_mm: 2.0 * radius,
            traceable_radius: true,
            directions,
            bidirectional: match (cw, ccw) {
                (Some((_, a)), Some((_, b))) => bidirectional(a, b),
                _ => None,
            },
            notes,
        });
    }
    out
}

/// Polar-plot data of one circle run (the identification result's `circles`): radial
/// deviation from the nominal radius, each path about its own least-squares centre, at
/// the bin angles, measured and from the fitted model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
pub struct CirclePlot {
    pub file: String,
    pub run: i64,
    pub plane: Plane,
    /// `cw` or `ccw`.
    pub direction: String,
    pub radius_mm: f64,
    /// LSC centre of the measured path (u, v), mm.
    pub centre_mm: [f64; 2],
    pub feed_mm_min: f64,
    pub start_angle_deg: f64,
    pub angle_deg: Vec<f64>,
    pub measured_um: Vec<f64>,
    /// Empty when no model was fitted.
    pub model_um: Vec<f64>,
}

/// Values rounded to 1e-4 µm (plot data; keeps documents small).
fn round(v: Vec<f64>) -> Vec<f64> {
    v.into_iter().map(|x| (x * 1e4).round() / 1e4).collect()
}

/// Polar-plot data of every circle run (values to 1e-4 µm). `residuals` (reading − model, indexed
/// [plane][run][sample] = (u, v), µm) gives the model's readings as reading − residual.
pub fn circle_plots(
    session: &Session,
    circles: &[CircleRun],
    residuals: Option<&[Vec<Vec<[f64; 2]>>]>,
) -> Vec<CirclePlot> {
    let mut out = vec![];
    for c in circles {
        let (p, r, path) = (c.plane, c.run, &c.path);
        let rec = &session.planes[p];
        let run = &rec.runs[r];
        let Some(l) = path.lsc() else {
            continue;
        };
        let model_um = residuals
            .and_then(|res| res.get(p)?.get(r))
            .filter(|res| res.len() == run.len())
            .and_then(|res| {
                let du: Vec<f64> = run
                    .du_um
                    .iter()
                    .zip(res.iter())
                    .map(|(d, e)| d - e[0])
                    .collect();
                let dv: Vec<f64> = run
                    .dv_um
                    .iter()
                    .zip(res.iter())
                    .map(|(d, e)| d - e[1])
                    .collect();
                let mp = c.geometry.path(run, &du, &dv);
                let ml = mp.lsc()?;
                Some(round(mp.radial_about(&ml)))
            })
            .unwrap_or_default();
        out.push(CirclePlot {
            file: rec.file.clone(),
            run: run.number,
            plane: rec.plane,
            direction: path.direction().into(),
            radius_mm: path.radius_mm,
            centre_mm: [
                path.centre_mm[0] + 1e-3 * l.b,
                path.centre_mm[1] + 1e-3 * l.c,
            ],
            feed_mm_min: path.feed_mm_min,
            start_angle_deg: path.start_angle_deg,
            measured_um: round(path.radial_about(&l)),
            angle_deg: path.angle_deg.clone(),
            model_um,
        });
    }
    out
}
