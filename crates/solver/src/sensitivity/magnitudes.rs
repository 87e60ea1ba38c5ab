//! Error magnitudes m_i(q): from tolerances, constant values, polynomials, tables, or an
//! identification result of the same machine.
//!
//! A tolerance is a bound ±T, constant over the travel: the local ranking weights the
//! sensitivity by T and the global analysis draws the error within ±T. A function
//! (coefficients or table) is the error's actual value; the global analysis scales it by a
//! random factor of the same distribution (within ±1).

use super::chain::{Chain, ErrorClass, ErrorSpec, MachineDescription};
use crate::identification::IdentificationResult;
use serde::{Deserialize, Serialize};

/// Where an error's magnitude came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[serde(rename_all = "snake_case")]
pub enum MagnitudeSource {
    Tolerance,
    Value,
    Polynomial,
    Table,
    /// Taken from the identification result.
    Identified,
    /// In the identification result but not identifiable there: the description's own
    /// magnitude is used.
    NotIdentifiable,
}

/// The magnitude of one error as a function of its axis position.
#[derive(Debug, Clone, PartialEq)]
pub enum Magnitude {
    Tolerance(f64),
    Value(f64),
    /// Σ c_i q^(i+1) (zero at q = 0).
    Polynomial(Vec<f64>),
    /// Linear interpolation, end values held outside the table.
    Table(Vec<f64>, Vec<f64>),
}

impl Magnitude {
    pub fn from_spec(s: &ErrorSpec) -> Magnitude {
        if let Some(t) = s.tolerance {
            Magnitude::Tolerance(t)
        } else if let Some(v) = s.value {
            Magnitude::Value(v)
        } else if let Some(c) = &s.coefficients {
            Magnitude::Polynomial(c.clone())
        } else {
            Magnitude::Table(
                s.positions.clone().unwrap_or_default(),
                s.values.clone().unwrap_or_default(),
            )
        }
    }

    fn source(&self) -> MagnitudeSource {
        match self {
            Magnitude::Tolerance(_) => MagnitudeSource::Tolerance,
            Magnitude::Value(_) => MagnitudeSource::Value,
            Magnitude::Polynomial(_) => MagnitudeSource::Polynomial,
            Magnitude::Table(..) => MagnitudeSource::Table,
        }
    }

    /// m(q): the tolerance, or the signed value of the error at axis position q.
    pub fn at(&self, q: f64) -> f64 {
        match self {
            Magnitude::Tolerance(t) => *t,
            Magnitude::Value(v) => *v,
            Magnitude::Polynomial(c) => c.iter().rev().fold(0.0, |acc, &ci| acc * q + ci) * q,
            Magnitude::Table(p, v) => interpolate(p, v, q),
        }
    }
}

fn interpolate(p: &[f64], v: &[f64], q: f64) -> f64 {
    if q <= p[0] {
        return v[0];
    }
    let n = p.len();
    if q >= p[n - 1] {
        return v[n - 1];
    }
    let k = p.partition_point(|&x| x <= q);
    let (p0, p1, v0, v1) = (p[k - 1], p[k], v[k - 1], v[k]);
    v0 + (v1 - v0) * (q - p0) / (p1 - p0)
}

/// Magnitudes of every parameter of a chain, in parameter order.
#[derive(Debug, Clone)]
pub struct Magnitudes {
    pub items: Vec<Magnitude>,
    pub sources: Vec<MagnitudeSource>,
    /// Axis (pose index) each magnitude depends on.
    axis: Vec<Option<usize>>,
}

impl Magnitudes {
    /// From the description's error specs, overridden by an identification result where
    /// it has the error (motion terms by name, squareness constants by name).
    pub fn new(
        chain: &Chain,
        desc: &MachineDescription,
        ident: Option<&IdentificationResult>,
    ) -> Magnitudes {
        let mut items = Vec::new();
        let mut sources = Vec::new();
        for p in chain.params() {
            let own = Magnitude::from_spec(&desc.errors[&p.name]);
            let mut src = own.source();
            let mut m = own;
            if let Some(id) = ident {
                match p.class {
                    ErrorClass::Motion => {
                        if let Some(t) = id.terms.get(&p.name) {
                            if t.identifiable && !t.coefficients.is_empty() {
                                m = Magnitude::Polynomial(t.coefficients.clone());
                                src = MagnitudeSource::Identified;
                            } else if t.identifiable && !t.positions_mm.is_empty() {
                                m = Magnitude::Table(t.positions_mm.clone(), t.values.clone());
                                src = MagnitudeSource::Identified;
                            } else {
                                src = MagnitudeSource::NotIdentifiable;
                            }
                        }
                    }
                    ErrorClass::Squareness => {
                        if let Some(s) = id.squareness.get(&p.name) {
                            match (s.identifiable, s.value_urad) {
                                (true, Some(v)) => {
                                    m = Magnitude::Value(v);
                                    src = MagnitudeSource::Identified;
                                }
                                _ => src = MagnitudeSource::NotIdentifiable,
                            }
                        }
                    }
                    _ => {}
                }
            }
            items.push(m);
            sources.push(src);
        }
        let axis = chain.params().iter().map(|p| p.axis).collect();
        Magnitudes {
            items,
            sources,
            axis,
        }
    }

    /// Tolerances only (every magnitude `Tolerance(t_i)`), for tests and linear studies.
    pub fn tolerances(chain: &Chain, t: &[f64]) -> Magnitudes {
        Magnitudes {
            items: t.iter().map(|&v| Magnitude::Tolerance(v)).collect(),
            sources: vec![MagnitudeSource::Tolerance; t.len()],
            axis: chain.params().iter().map(|p| p.axis).collect(),
        }
    }

    /// m_i(q) for every parameter at pose q, into `out`.
    pub fn at_pose(&self, q: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.items.iter().zip(&self.axis).map(|(m, a)| match a {
            Some(k) => m.at(q[*k]),
            None => m.at(0.0),
        }));
    }

    /// The machine's error state at pose q: values and functions as given, tolerances 0.
    pub fn state_at_pose(&self, q: &[f64], out: &mut Vec<f64>) {
        self.at_pose(q, out);
        for (v, m) in out.iter_mut().zip(&self.items) {
            if matches!(m, Magnitude::Tolerance(_)) {
                *v = 0.0;
            }
        }
    }

    /// Whether some error is given as a value or a function (not only tolerances).
    pub fn has_values(&self) -> bool {
        self.items
            .iter()
            .any(|m| !matches!(m, Magnitude::Tolerance(_)))
    }

    /// Whether some magnitude depends on an axis position (a function of a motion error).
    pub fn varies_with_position(&self) -> bool {
        self.items.iter().zip(&self.axis).any(|(m, a)| {
            a.is_some() && matches!(m, Magnitude::Polynomial(_) | Magnitude::Table(..))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_and_table_evaluate_as_documented() {
        let p = Magnitude::Polynomial(vec![0.01, 1e-4]);
        assert!((p.at(100.0) - (1.0 + 1.0)).abs() < 1e-12);
        assert_eq!(p.at(0.0), 0.0);
        let t = Magnitude::Table(vec![0.0, 10.0, 20.0], vec![0.0, 2.0, -2.0]);
        assert!((t.at(5.0) - 1.0).abs() < 1e-12);
        assert!((t.at(15.0) - 0.0).abs() < 1e-12);
        assert_eq!(t.at(-5.0), 0.0);
        assert_eq!(t.at(25.0), -2.0);
    }
}
