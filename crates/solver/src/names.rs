//! What a person calls each judged quantity: the code names under which quantities are
//! stored, trended and given limits (`EXX`, `EC0Y`, `iso230_2.X.E_um`,
//! `iso230_4.XY.cw.mean_radial_um`) as a person says them ("X axis: positioning",
//! "squareness X–Y", "ISO 230-2, X: E, bidirectional systematic positional deviation",
//! "ISO 230-4, XY, clockwise: mean radial deviation").
//!
//! | code name | in words |
//! |---|---|
//! | `EXX`, `EYX`, `EAX`, `EBX` | X axis: positioning; straightness in Y; roll; pitch (about Y) |
//! | `EC0Y`, `EB0Z`, `EA0Z` | squareness X–Y, X–Z, Y–Z |
//! | `iso230_2.<axis>.<figure>` | ISO 230-2, axis: symbol, the standard's name |
//! | `iso230_4.<plane>.<cw\|ccw\|bi>.<figure>` | ISO 230-4, plane, clockwise / counter-clockwise / both directions: name |
//!
//! A code name this table does not know is returned as it is.

use crate::standards::{iso230_2, iso230_4};
use crate::terms::{Component, SquarenessTerm, Term, TermKind};

/// `name` as a person says it (module table); an unknown name unchanged.
pub fn in_words(name: &str) -> String {
    term(name)
        .or_else(|| squareness(name))
        .or_else(|| standard(name))
        .unwrap_or_else(|| name.to_string())
}

/// The group a quantity is counted in when it is summarised: `error functions`,
/// `squareness`, `ISO 230-2, X`, `ISO 230-4, XY`; else the name's first part.
pub fn group(name: &str) -> String {
    if Term::parse(name).is_some() {
        return "error functions".into();
    }
    if SquarenessTerm::parse(name).is_some() {
        return "squareness".into();
    }
    let mut parts = name.split('.');
    match (parts.next(), parts.next()) {
        (Some("iso230_2"), Some(axis)) => format!("ISO 230-2, {axis}"),
        (Some("iso230_4"), Some(plane)) => format!("ISO 230-4, {plane}"),
        (Some(first), _) => first.to_string(),
        _ => name.to_string(),
    }
}

/// A list of ISO 230-2 figures in short, by symbol and axis: `ISO 230-2 B, B̄, R of X,
/// Y` (other names in words, joined by `; `).
pub fn figures_in_words(names: &[String]) -> String {
    let (mut symbols, mut axes, mut others) = (vec![], vec![], vec![]);
    for n in names {
        let parts: Vec<&str> = n.split('.').collect();
        match parts.as_slice() {
            ["iso230_2", axis, figure] if iso230_2::figure_name(figure).is_some() => {
                let symbol = iso230_2::figure_name(figure).map_or(*figure, |f| f.0);
                if !symbols.contains(&symbol) {
                    symbols.push(symbol);
                }
                if !axes.contains(axis) {
                    axes.push(*axis);
                }
            }
            _ => others.push(in_words(n)),
        }
    }
    if !symbols.is_empty() {
        others.insert(
            0,
            format!("ISO 230-2 {} of {}", symbols.join(", "), axes.join(", ")),
        );
    }
    others.join("; ")
}

fn term(name: &str) -> Option<String> {
    let t = Term::parse(name)?;
    let a = t.axis;
    let what = match (t.kind(), t.component) {
        (TermKind::Positioning, _) => "positioning".to_string(),
        (TermKind::Straightness, Component::Translation(d)) => format!("straightness in {d}"),
        (TermKind::Roll, _) => "roll".to_string(),
        (_, Component::Rotation(d)) => {
            // ISO 230-1: X pitches about Y and yaws about Z; Y pitches about X and yaws
            // about Z; Z tilts about X and Y.
            let word = match (a.letter(), d.letter()) {
                ('X', 'Y') | ('Y', 'X') => "pitch",
                ('X', 'Z') | ('Y', 'Z') => "yaw",
                _ => "tilt",
            };
            format!("{word} (about {d})")
        }
        (_, Component::Translation(d)) => format!("error in {d}"),
    };
    Some(format!("{a} axis: {what}"))
}

fn squareness(name: &str) -> Option<String> {
    let pair = match SquarenessTerm::parse(name)? {
        SquarenessTerm::EC0Y => "X–Y",
        SquarenessTerm::EB0Z => "X–Z",
        SquarenessTerm::EA0Z => "Y–Z",
    };
    Some(format!("squareness {pair}"))
}

fn standard(name: &str) -> Option<String> {
    let parts: Vec<&str> = name.split('.').collect();
    match parts.as_slice() {
        ["iso230_2", axis, figure] => {
            let (symbol, words) = iso230_2::figure_name(figure)?;
            Some(format!("ISO 230-2, {axis}: {symbol}, {words}"))
        }
        ["iso230_4", plane, direction, figure] => {
            let direction = match *direction {
                "cw" => "clockwise",
                "ccw" => "counter-clockwise",
                "bi" => "both directions",
                _ => return None,
            };
            let (symbol, words) = iso230_4::figure_name(figure)?;
            // "mean radial deviation" is a name of its own; G, H and F carry a symbol.
            let said = if symbol.contains(' ') && !symbol.starts_with('F') {
                symbol.to_string()
            } else {
                format!("{symbol}, {words}")
            };
            Some(format!("ISO 230-4, {plane}, {direction}: {said}"))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn code_names_read_as_a_person_says_them() {
        assert_eq!(
            in_words("iso230_4.XY.cw.mean_radial_um"),
            "ISO 230-4, XY, clockwise: mean radial deviation"
        );
        assert_eq!(
            in_words("iso230_4.YZ.bi.H_um"),
            "ISO 230-4, YZ, both directions: H, circular hysteresis"
        );
        assert_eq!(
            in_words("iso230_4.XZ.ccw.F_max_um"),
            "ISO 230-4, XZ, counter-clockwise: F max, radial deviation, largest"
        );
        assert_eq!(
            in_words("iso230_2.X.E_um"),
            "ISO 230-2, X: E, bidirectional systematic positional deviation"
        );
        assert_eq!(in_words("EXX"), "X axis: positioning");
        assert_eq!(in_words("EYX"), "X axis: straightness in Y");
        assert_eq!(in_words("EAX"), "X axis: roll");
        assert_eq!(in_words("EBX"), "X axis: pitch (about Y)");
        assert_eq!(in_words("ECY"), "Y axis: yaw (about Z)");
        assert_eq!(in_words("EAZ"), "Z axis: tilt (about X)");
        assert_eq!(in_words("EC0Y"), "squareness X–Y");
        assert_eq!(in_words("something.else"), "something.else");
        assert_eq!(group("iso230_4.XY.cw.G_um"), "ISO 230-4, XY");
        assert_eq!(group("iso230_2.Z.M_um"), "ISO 230-2, Z");
        assert_eq!(group("EZZ"), "error functions");
        assert_eq!(group("EB0Z"), "squareness");
        let listed: Vec<String> = [
            "iso230_2.X.B_um",
            "iso230_2.X.R_um",
            "iso230_2.Y.B_um",
            "EXX",
        ]
        .map(String::from)
        .to_vec();
        assert_eq!(
            figures_in_words(&listed),
            "ISO 230-2 B, R of X, Y; X axis: positioning"
        );
    }
}
