//! How quantities are written for a person, in every output of mtcal (pages, reports,
//! the CLI's summaries, alert messages, the sentences of result documents): one rule,
//! the digits suit the number's size, and never a negative zero (`-0.000` reads `0.000`).
//!
//! | function | writes | example |
//! |---|---|---|
//! | [`num`] | 3 decimals below 10, 2 below 100, 1 below 100 000, then 4 significant digits in scientific form | `0.300`, `28.54`, `214.2`, `1.712e7` |
//! | [`signed`] | [`num`] with `+` on a positive number | `+0.125`, `-3.200` |
//! | [`short`] | at most 4 significant digits, trailing zeros dropped (numbers inside sentences) | `0.0004`, `28.54`, `1.5` |
//! | [`with_std`] | `value ± σ`, σ to two significant digits and the value to its place (GUM 7.2.6) | `6.60 ± 0.30` |
//! | [`with_u`] | `value ± U unit`, U = 2u, both by [`num`] | `3.210 ± 0.100 µm` |
//!
//! Units as a person writes them: [`unit_label`] (`µm`, `µrad`, never `um`); a
//! parameter's name and unit: [`parameter_name`] (`lost_motion_um` → `lost motion`, `µm`).

/// `um` → `µm`, `urad` → `µrad`, anything else unchanged.
pub fn unit_label(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        other => other,
    }
}

/// Units of the parameter names of mtcal's documents, by suffix, longest first.
const PARAMETER_UNITS: [(&str, &str); 11] = [
    ("_um_per_mm_s", "µm/(mm/s)"),
    ("_ppm_per_k", "ppm/K"),
    ("_um_per_k", "µm/K"),
    ("_um_per_mm", "µm/mm"),
    ("_urad", "µrad"),
    ("_ppm", "ppm"),
    ("_um", "µm"),
    ("_mm", "mm"),
    ("_hz", "Hz"),
    ("_deg", "°"),
    ("_s", "s"),
];

/// A parameter's name in words and its unit as a person writes them:
/// `lost_motion_um` → (`lost motion`, `µm`), `scale_ppm_per_k` → (`scale`, `ppm/K`),
/// `time_constant_s` → (`time constant`, `s`); without a known unit, (words, ``).
pub fn parameter_name(key: &str) -> (String, &'static str) {
    PARAMETER_UNITS
        .iter()
        .find_map(|(suffix, unit)| Some((key.strip_suffix(suffix)?.replace('_', " "), *unit)))
        .unwrap_or_else(|| (key.replace('_', " "), ""))
}

/// A number with a precision that suits its size: 3 decimals below 10, 2 below 100,
/// 1 below 100 000, then 4 significant digits in scientific form (`1.712e7`).
pub fn num(v: f64) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    let a = v.abs();
    let s = if a >= 1e5 {
        format!("{v:.3e}")
    } else if a < 10.0 {
        format!("{v:.3}")
    } else if a < 100.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.1}")
    };
    unsigned_zero(s)
}

/// `s` without its minus sign when every digit of it is zero (`-0.000` → `0.000`).
fn unsigned_zero(s: String) -> String {
    match s.strip_prefix('-') {
        Some(rest)
            if !rest
                .split('e')
                .next()
                .unwrap_or("")
                .contains(|c: char| ('1'..='9').contains(&c)) =>
        {
            rest.to_string()
        }
        _ => s,
    }
}

/// [`num`] with a `+` on a positive number (`+0.125`); zero has no sign.
pub fn signed(v: f64) -> String {
    let s = num(v);
    if v > 0.0 && s.contains(|c: char| ('1'..='9').contains(&c)) {
        format!("+{s}")
    } else {
        s
    }
}

/// A number inside a sentence: at most 4 significant digits, trailing zeros dropped, no
/// float noise (`0.0004`, `28.54`, `1.5`); zero and non-finite numbers as Rust writes them.
pub fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{}", if v == 0.0 { 0.0 } else { v });
    }
    let digits = (4 - 1 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{v:.digits$}");
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    unsigned_zero(s)
}

/// `value ± σ` with σ (a standard uncertainty) to two significant digits and the value to
/// the same decimal place (GUM 7.2.6): `0.00026 ± 0.0000042` reads `0.0002600 ± 0.0000042`,
/// never `± 0.00`; at least `min_decimals` decimals, at most 12. `sign` writes `+` on a
/// positive value. A σ that is zero or not finite leaves the value with `min_decimals`.
pub fn with_std(value: f64, std: f64, min_decimals: usize, sign: bool) -> String {
    let d = if std.is_finite() && std > 0.0 {
        (1 - std.log10().floor() as i64).clamp(min_decimals as i64, 12) as usize
    } else {
        min_decimals
    };
    let v = if sign {
        format!("{value:+.d$}")
    } else {
        format!("{value:.d$}")
    };
    let v = unsigned_zero(v.trim_start_matches('+').to_string());
    let v = if sign && value > 0.0 && v.contains(|c: char| ('1'..='9').contains(&c)) {
        format!("+{v}")
    } else {
        v
    };
    format!("{v} ± {std:.d$}")
}

/// `value ± U unit` with U = 2u; `value unit` when u is unknown; `—` without a value.
pub fn with_u(value: Option<f64>, u: Option<f64>, unit: &str) -> String {
    let unit = unit_label(unit);
    match (value, u) {
        (Some(v), Some(u)) if u.is_finite() => format!("{} ± {} {unit}", num(v), num(2.0 * u)),
        (Some(v), _) => format!("{} {unit}", num(v)),
        (None, _) => "—".into(),
    }
}

/// `text` with the unit words `um` and `urad` written as a person writes them (`µm`,
/// `µrad`): for messages and labels written in ASCII (`RMS (um)` → `RMS (µm)`, `um/K`
/// → `µm/K`). Only whole words change: `sum`, `du_um` and `umbrella` stay as they are.
pub fn person_units(text: &str) -> String {
    let word = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = String::with_capacity(text.len() + 8);
    let mut rest = text;
    let mut prev: Option<char> = None;
    while let Some(c) = rest.chars().next() {
        let starts_word = prev.is_none_or(|p| !word(p));
        let unit = ["urad", "um"]
            .into_iter()
            .find(|u| starts_word && rest.starts_with(u) && !rest[u.len()..].starts_with(word));
        match unit {
            Some(u) => {
                out.push_str(unit_label(u));
                rest = &rest[u.len()..];
                prev = u.chars().last();
            }
            None => {
                out.push(c);
                rest = &rest[c.len_utf8()..];
                prev = Some(c);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {

    #[test]
    fn parameter_names_in_words() {
        assert_eq!(
            parameter_name("lost_motion_um"),
            ("lost motion".into(), "µm")
        );
        assert_eq!(parameter_name("scale_ppm_per_k"), ("scale".into(), "ppm/K"));
        assert_eq!(parameter_name("t14_um_per_k"), ("t14".into(), "µm/K"));
        assert_eq!(
            parameter_name("time_constant_s"),
            ("time constant".into(), "s")
        );
        assert_eq!(
            parameter_name("share_predicted"),
            ("share predicted".into(), "")
        );
    }

    use super::*;

    /// Two significant digits of σ, the value to the same place; never `± 0.00`.
    #[test]
    fn a_standard_uncertainty_keeps_two_significant_digits() {
        assert_eq!(
            with_std(0.000_26, 0.000_004_2, 2, false),
            "0.0002600 ± 0.0000042"
        );
        assert_eq!(with_std(6.6043, 0.3012, 2, false), "6.60 ± 0.30");
        assert_eq!(with_std(-0.95, 0.0031, 2, true), "-0.9500 ± 0.0031");
        assert_eq!(with_std(12.5, 3.4, 2, true), "+12.50 ± 3.40");
        assert_eq!(with_std(1.0, f64::INFINITY, 2, false), "1.00 ± inf");
    }

    #[test]
    fn unit_words_in_text_are_written_as_a_person_writes_them() {
        assert_eq!(person_units("RMS (um)"), "RMS (µm)");
        assert_eq!(person_units("um/K and urad, 3 um"), "µm/K and µrad, 3 µm");
        assert_eq!(person_units("um"), "µm");
        for same in ["sum", "du_um", "umbrella", "drum kit", "µm", "forum: um2"] {
            assert_eq!(person_units(same), same);
        }
    }

    #[test]
    fn numbers_and_units_as_a_person_writes_them() {
        assert_eq!(with_u(Some(3.2104), Some(0.05), "um"), "3.210 ± 0.100 µm");
        assert_eq!(with_u(Some(-123.45), None, "urad"), "-123.5 µrad");
        assert_eq!(with_u(None, Some(1.0), "um"), "—");
        assert_eq!(num(214.21033695945158), "214.2");
        assert_eq!(num(17_123_456.0), "1.712e7");
        assert_eq!(num(-0.0004), "0.000");
        assert_eq!(num(-0.0), "0.000");
        assert_eq!(num(-0.04), "-0.040");
        assert_eq!(num(-1e-9), "0.000");
        assert_eq!(signed(0.125), "+0.125");
        assert_eq!(signed(-0.0001), "0.000");
        assert_eq!(signed(-3.2), "-3.200");
        assert_eq!(short(28.541666666666664), "28.54");
        assert_eq!(short(-0.00001), "-0.00001");
        assert_eq!(short(-0.0), "0");
        assert_eq!(short(1.5), "1.5");
        assert_eq!(with_std(-0.0001, 0.3, 2, false), "0.00 ± 0.30");
        assert_eq!(num(f64::NAN), "—");
        assert_eq!(unit_label("mm"), "mm");
    }
}
