//! Strict JSON documents (session.json, rotary sidecars): parse with `serde_json`, then
//! validate field by field so that every error names the field path (`planes[1].plane`)
//! and the line where it appears. Unknown fields are rejected unless their name starts
//! with `x-` (datasets contract, "Rules for every format").

use crate::FormatError;
use crate::csv_core::{IGNORED_PREFIX, UTF8_BOM};
use crate::limits::{Limits, Quantity};
use serde_json::{Map, Value};
use std::collections::HashMap;

/// A parsed JSON document with the line of every value, by path.
pub(crate) struct JsonDoc<'a> {
    pub file: &'a str,
    pub value: Value,
    lines: HashMap<String, u64>,
}

impl<'a> JsonDoc<'a> {
    pub fn parse(file: &'a str, bytes: &[u8]) -> Result<Self, FormatError> {
        let bytes = bytes.strip_prefix(UTF8_BOM.as_slice()).unwrap_or(bytes);
        let text = std::str::from_utf8(bytes).map_err(|e| {
            let line = 1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            FormatError::new(file, line as u64, "", "file is not valid UTF-8")
        })?;
        let value: Value = serde_json::from_str(text).map_err(|e| {
            FormatError::new(file, e.line() as u64, "", format!("invalid JSON: {e}"))
        })?;
        let mut lines = HashMap::new();
        Locator {
            b: text.as_bytes(),
            p: 0,
            line: 1,
        }
        .value("", &mut lines);
        Ok(JsonDoc { file, value, lines })
    }

    /// Line where the value at `path` starts (its key, for object members), or the line
    /// of the closest enclosing value that exists.
    pub fn line(&self, path: &str) -> u64 {
        let mut p = path;
        loop {
            if let Some(&l) = self.lines.get(p) {
                return l;
            }
            match p.rfind(['.', '[']) {
                Some(i) => p = &p[..i],
                None => return self.lines.get("").copied().unwrap_or(1),
            }
        }
    }

    pub fn error(&self, path: &str, rule: impl Into<String>) -> FormatError {
        FormatError::new(self.file, self.line(path), path, rule)
    }

    /// The root as an object.
    pub fn root(&self) -> Result<Obj<'_>, FormatError> {
        match &self.value {
            Value::Object(map) => Ok(Obj {
                doc: self,
                path: String::new(),
                map,
            }),
            _ => Err(self.error("", "the document must be a JSON object")),
        }
    }
}

/// One JSON object being validated, at `path`.
pub(crate) struct Obj<'d> {
    pub doc: &'d JsonDoc<'d>,
    pub path: String,
    pub map: &'d Map<String, Value>,
}

impl<'d> Obj<'d> {
    pub fn field_path(&self, field: &str) -> String {
        if self.path.is_empty() || field.is_empty() {
            format!("{}{field}", self.path)
        } else {
            format!("{}.{field}", self.path)
        }
    }

    pub fn error(&self, field: &str, rule: impl Into<String>) -> FormatError {
        self.doc.error(&self.field_path(field), rule)
    }

    /// Rejects members that are neither in `allowed` nor `x-` prefixed.
    pub fn check_fields(&self, allowed: &[&str]) -> Result<(), FormatError> {
        for key in self.map.keys() {
            if !key.starts_with(IGNORED_PREFIX) && !allowed.contains(&key.as_str()) {
                return Err(self.error(
                    key,
                    format!(
                        "unknown field (expected one of {}; other fields must start with `{IGNORED_PREFIX}`)",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The member, treating `null` as absent.
    pub fn get(&self, field: &str) -> Option<&'d Value> {
        self.map.get(field).filter(|v| !v.is_null())
    }

    pub fn required(&self, field: &str) -> Result<&'d Value, FormatError> {
        self.get(field)
            .ok_or_else(|| self.error(field, "required field is missing"))
    }

    pub fn opt_str(&self, field: &str) -> Result<Option<&'d str>, FormatError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(_) => Err(self.error(field, "must be a string")),
        }
    }

    /// A required, non-blank string.
    pub fn req_str(&self, field: &str) -> Result<&'d str, FormatError> {
        match self.opt_str(field)? {
            None => Err(self.error(field, "required field is missing")),
            Some(s) if s.trim().is_empty() => Err(self.error(field, "must not be empty")),
            Some(s) => Ok(s),
        }
    }

    /// An optional finite number within the bound of its quantity `q`, refused as a CSV
    /// cell of that quantity is ([`Quantity::beyond`]).
    pub fn opt_f64_within(
        &self,
        field: &str,
        q: Quantity,
        limits: &Limits,
    ) -> Result<Option<f64>, FormatError> {
        let v = self.opt_f64(field)?;
        match v.and_then(|x| q.beyond(x, limits)) {
            Some(why) => Err(self.error(field, why)),
            None => Ok(v),
        }
    }

    pub fn opt_f64(&self, field: &str) -> Result<Option<f64>, FormatError> {
        match self.get(field) {
            None => Ok(None),
            Some(v) => v
                .as_f64()
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| self.error(field, "must be a finite number")),
        }
    }

    /// A member object.
    pub fn object(&self, field: &str, value: &'d Value) -> Result<Obj<'d>, FormatError> {
        match value {
            Value::Object(map) => Ok(Obj {
                doc: self.doc,
                path: self.field_path(field),
                map,
            }),
            _ => Err(self.error(field, "must be an object")),
        }
    }

    /// An optional RFC 3339 time stamp.
    pub fn opt_timestamp(&self, field: &str) -> Result<Option<&'d str>, FormatError> {
        let s = self.opt_str(field)?;
        if let Some(s) = s
            && !is_rfc3339(s)
        {
            return Err(self.error(
                field,
                format!("`{s}` is not an RFC 3339 time stamp (e.g. 2026-11-02T08:30:00Z)"),
            ));
        }
        Ok(s)
    }
}

/// RFC 3339 `date-time`: `YYYY-MM-DDTHH:MM:SS[.frac](Z|±HH:MM)` (`t`, `z` and a space for
/// `T` accepted, as RFC 3339 section 5.6 allows), with field ranges checked.
pub fn is_rfc3339(s: &str) -> bool {
    let b = s.as_bytes();
    let num = |r: std::ops::Range<usize>, lo: u32, hi: u32| -> bool {
        b.get(r.clone())
            .is_some_and(|d| d.iter().all(u8::is_ascii_digit))
            && s[r].parse::<u32>().is_ok_and(|v| (lo..=hi).contains(&v))
    };
    if b.len() < 20
        || !num(0..4, 0, 9999)
        || b[4] != b'-'
        || !num(5..7, 1, 12)
        || b[7] != b'-'
        || !num(8..10, 1, 31)
        || !matches!(b[10], b'T' | b't' | b' ')
        || !num(11..13, 0, 23)
        || b[13] != b':'
        || !num(14..16, 0, 59)
        || b[16] != b':'
        || !num(17..19, 0, 60)
    {
        return false;
    }
    let mut i = 19;
    if b[i] == b'.' {
        let start = i + 1;
        i = start;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == start {
            return false;
        }
    }
    match &b[i..] {
        [b'Z' | b'z'] => true,
        [b'+' | b'-', ..] if b.len() - i == 6 => {
            num(i + 1..i + 3, 0, 23) && b[i + 3] == b':' && num(i + 4..i + 6, 0, 59)
        }
        _ => false,
    }
}

/// Records the starting line of every value of an already validated JSON text, by path
/// (`a.b[2].c`); object members are recorded at the line of their key.
struct Locator<'t> {
    b: &'t [u8],
    p: usize,
    line: u64,
}

impl Locator<'_> {
    fn ws(&mut self) {
        while let Some(&c) = self.b.get(self.p) {
            match c {
                b'\n' => self.line += 1,
                b' ' | b'\t' | b'\r' => {}
                _ => return,
            }
            self.p += 1;
        }
    }

    fn string(&mut self) -> String {
        // At the opening quote of a valid string.
        let start = self.p;
        self.p += 1;
        while let Some(&c) = self.b.get(self.p) {
            self.p += 1;
            match c {
                b'\\' => self.p += 1,
                b'"' => break,
                _ => {}
            }
        }
        serde_json::from_slice(&self.b[start..self.p]).unwrap_or_default()
    }

    fn value(&mut self, path: &str, out: &mut HashMap<String, u64>) {
        self.ws();
        out.entry(path.to_string()).or_insert(self.line);
        match self.b.get(self.p) {
            Some(b'{') => {
                self.p += 1;
                loop {
                    self.ws();
                    match self.b.get(self.p) {
                        Some(b'"') => {
                            let line = self.line;
                            let key = self.string();
                            let child = if path.is_empty() {
                                key
                            } else {
                                format!("{path}.{key}")
                            };
                            out.insert(child.clone(), line);
                            self.ws();
                            self.p += 1; // ':'
                            self.value(&child, out);
                        }
                        Some(b',') => self.p += 1,
                        Some(_) => {
                            self.p += 1; // '}'
                            return;
                        }
                        None => return,
                    }
                }
            }
            Some(b'[') => {
                self.p += 1;
                let mut i = 0;
                loop {
                    self.ws();
                    match self.b.get(self.p) {
                        Some(b']') => {
                            self.p += 1;
                            return;
                        }
                        Some(b',') => self.p += 1,
                        Some(_) => {
                            self.value(&format!("{path}[{i}]"), out);
                            i += 1;
                        }
                        None => return,
                    }
                }
            }
            Some(b'"') => {
                self.string();
            }
            Some(_) => {
                while let Some(&c) = self.b.get(self.p) {
                    if matches!(c, b',' | b'}' | b']' | b' ' | b'\t' | b'\r' | b'\n') {
                        break;
                    }
                    self.p += 1;
                }
            }
            None => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rfc3339() {
        for ok in [
            "2026-11-02T08:30:00Z",
            "2026-11-02t08:30:00.125z",
            "2026-11-02 08:30:00+01:00",
            "2026-11-02T23:59:60-05:30",
        ] {
            assert!(is_rfc3339(ok), "{ok}");
        }
        for bad in [
            "2026-11-02",
            "2026-13-02T08:30:00Z",
            "2026-11-02T08:30:00",
            "2026-11-02T08:30:00.Z",
            "2026-11-02T24:00:00Z",
            "2026-11-02T08:30:00+0100",
            "yesterday",
        ] {
            assert!(!is_rfc3339(bad), "{bad}");
        }
    }

    #[test]
    fn locator_lines() {
        let text =
            "{\n \"a\": 1,\n \"b\": [\n  {\"c\": 2},\n  {\n   \"c\": \"x\\\"y\"\n  }\n ]\n}\n";
        let doc = JsonDoc::parse("f.json", text.as_bytes()).unwrap();
        assert_eq!(doc.line("a"), 2);
        assert_eq!(doc.line("b"), 3);
        assert_eq!(doc.line("b[0].c"), 4);
        assert_eq!(doc.line("b[1]"), 5);
        assert_eq!(doc.line("b[1].c"), 6);
        // Missing members fall back to their parent.
        assert_eq!(doc.line("b[1].missing"), 5);
    }
}
