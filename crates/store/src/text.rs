//! The rules of every text field a client gives, checked once before anything is stored
//! so that both backends accept and refuse the same inputs: PostgreSQL refuses a NUL byte
//! in a text value and an index row over about 2.7 kB, SQLite neither; a rule checked
//! here refuses them on both, with a message naming the field, before a statement runs.
//!
//! * **Identifiers** (machine ids): 1 to [`ID_MAX`] characters of letters, digits, `.`,
//!   `_` and `-`, not `.` or `..` (they name no path segment that can be reached).
//! * **Lines** (names, sites, tags, key labels, tolerance targets, who did something):
//!   not empty or only blanks, at most the field's number of characters, no control
//!   character (Unicode category Cc: U+0000–U+001F, U+007F–U+009F).
//! * **Free text** (reasons, comments): as a line, but line feeds and tabs are allowed.
//! * **Tags**: at most [`TAGS_MAX`] of them, each a line of at most [`TAG_MAX`]
//!   characters, none given twice, and the list as stored (JSON, UTF-8) at most
//!   [`TAGS_BYTES_MAX`] bytes: the list is one indexed value.
//!
//! Lengths count characters (Unicode scalar values); every single cap times 4 (the
//! longest UTF-8 character) stays below PostgreSQL's index row limit (2704 bytes), and
//! an indexed value made of several parts (the tag list) is bounded as a whole.

use crate::error::{Result, StoreError};

pub use mtcal_api::limits::{
    BY_MAX, ID_MAX, LABEL_MAX, NAME_MAX, REASON_MAX, SITE_MAX, TAG_MAX, TAGS_BYTES_MAX, TAGS_MAX,
    TARGET_MAX,
};

fn invalid(m: String) -> StoreError {
    StoreError::Invalid(m)
}

/// The first control character of `s` that `allowed` does not admit, as `U+XXXX`.
fn control(s: &str, allowed: &[char]) -> Option<String> {
    s.chars()
        .find(|c| c.is_control() && !allowed.contains(c))
        .map(|c| format!("U+{:04X}", c as u32))
}

fn check(field: &str, value: &str, max: usize, allowed: &[char]) -> Result<()> {
    if value.trim().is_empty() {
        return Err(invalid(format!("{field}: must not be empty")));
    }
    let n = value.chars().count();
    if n > max {
        return Err(invalid(format!(
            "{field}: at most {max} characters, got {n}"
        )));
    }
    if let Some(c) = control(value, allowed) {
        return Err(invalid(format!("{field}: holds the control character {c}")));
    }
    Ok(())
}

/// Checks a one-line field: not blank, at most `max` characters, no control character.
pub fn check_line(field: &str, value: &str, max: usize) -> Result<()> {
    check(field, value, max, &[])
}

/// Checks a free-text field: as [`check_line`], line feeds and tabs allowed.
pub fn check_free_text(field: &str, value: &str, max: usize) -> Result<()> {
    check(field, value, max, &['\n', '\t'])
}

/// Checks an identifier (see the module documentation).
pub fn check_id(field: &str, id: &str) -> Result<()> {
    let chars_ok = id
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if !(1..=ID_MAX).contains(&id.len()) || !chars_ok || id == "." || id == ".." {
        return Err(invalid(format!(
            "{field} {:?}: 1-{ID_MAX} characters, letters, digits, '.', '_' or '-' \
             (not '.' or '..')",
            id.chars().take(ID_MAX + 1).collect::<String>()
        )));
    }
    Ok(())
}

/// Checks a machine's tags (see the module documentation).
pub fn check_tags(tags: &[String]) -> Result<()> {
    if tags.len() > TAGS_MAX {
        return Err(invalid(format!(
            "tags: at most {TAGS_MAX}, got {}",
            tags.len()
        )));
    }
    for (i, t) in tags.iter().enumerate() {
        check_line(&format!("tags[{i}]"), t, TAG_MAX)?;
        if tags[..i].contains(t) {
            return Err(invalid(format!("tags[{i}]: {t:?} is given twice")));
        }
    }
    let stored = serde_json::to_string(tags).map_or(usize::MAX, |j| j.len());
    if stored > TAGS_BYTES_MAX {
        return Err(invalid(format!(
            "tags: at most {TAGS_BYTES_MAX} bytes together as stored (UTF-8, a JSON list), \
             got {stored}: use fewer or shorter tags"
        )));
    }
    Ok(())
}

/// Checks the text fields of a machine as it is about to be stored.
pub fn check_machine(m: &crate::Machine) -> Result<()> {
    check_id("id", &m.id)?;
    check_line("name", &m.name, NAME_MAX)?;
    if let Some(site) = &m.site {
        check_line("site", site, SITE_MAX)?;
    }
    check_tags(&m.tags)
}

/// Most sites one key may name.
pub const KEY_SITES_MAX: usize = 100;

/// Checks a key's scope: at most [`KEY_SITES_MAX`] sites, each a site line, none twice;
/// its tags as a machine's.
pub fn check_key_scope(sites: &[String], tags: &[String]) -> Result<()> {
    if sites.len() > KEY_SITES_MAX {
        return Err(invalid(format!(
            "sites: at most {KEY_SITES_MAX}, got {}",
            sites.len()
        )));
    }
    for (i, s) in sites.iter().enumerate() {
        check_line(&format!("sites[{i}]"), s, SITE_MAX)?;
        if sites[..i].contains(s) {
            return Err(invalid(format!("sites[{i}]: {s:?} is given twice")));
        }
    }
    check_tags(tags)
}

/// Checks a record of who did what and why (exclusions, deletions).
pub fn check_record(by: &str, reason: &str) -> Result<()> {
    check_line("by", by, BY_MAX)?;
    check_free_text("reason", reason, REASON_MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_refuse_control_characters_blanks_and_length() {
        check_line("name", "VMC 1 – Halle Süd", NAME_MAX).unwrap();
        for (bad, says) in [
            ("x\u{0}y", "U+0000"),
            ("x\ny", "U+000A"),
            ("x\u{7f}", "U+007F"),
            ("x\u{85}", "U+0085"),
            ("   ", "empty"),
            ("", "empty"),
        ] {
            let e = check_line("name", bad, NAME_MAX).unwrap_err().to_string();
            assert!(e.contains("name:") && e.contains(says), "{bad:?}: {e}");
        }
        check_line("name", &"é".repeat(NAME_MAX), NAME_MAX).unwrap();
        let e = check_line("name", &"é".repeat(NAME_MAX + 1), NAME_MAX).unwrap_err();
        assert!(e.to_string().contains("at most 200"), "{e}");
        check_free_text("reason", "line one\n\tline two", REASON_MAX).unwrap();
        assert!(check_free_text("reason", "a\rb", REASON_MAX).is_err());
    }

    #[test]
    fn ids_are_plain_and_reachable() {
        for ok in ["VMC-0001", "a.b_c", "...", "x"] {
            check_id("id", ok).unwrap();
        }
        for bad in [".", "..", "", "a/b", "a b", "a\u{0}b", &"x".repeat(65)] {
            assert!(check_id("id", bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn tags_are_few_short_and_distinct() {
        let t = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        check_tags(&t(&["vmc", "hall-2"])).unwrap();
        check_tags(&[]).unwrap();
        assert!(check_tags(&t(&["vmc", "vmc"])).is_err());
        assert!(check_tags(&t(&[""])).is_err());
        assert!(check_tags(&["x".repeat(TAG_MAX + 1)]).is_err());
        let many: Vec<String> = (0..=TAGS_MAX).map(|i| format!("t{i}")).collect();
        assert!(
            check_tags(&many)
                .unwrap_err()
                .to_string()
                .contains("at most 32")
        );
        // The list is one indexed value: bounded as a whole, as stored.
        let cjk = |n: usize| -> Vec<String> {
            (0..n)
                .map(|i| {
                    char::from_u32(0x4e00 + i as u32)
                        .unwrap()
                        .to_string()
                        .repeat(TAG_MAX)
                })
                .collect()
        };
        check_tags(&cjk(12)).unwrap();
        let e = check_tags(&cjk(14)).unwrap_err().to_string();
        assert!(e.contains("2400 bytes together"), "{e}");
        let ascii: Vec<String> = (0..TAGS_MAX).map(|i| format!("{i:064}")).collect();
        check_tags(&ascii).unwrap();
    }
}
