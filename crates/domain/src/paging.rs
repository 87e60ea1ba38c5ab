//! The one rule of every `limit` a list takes: a whole number from 1 to the list's
//! maximum, else the request is refused (400) with the range; never clamped silently.
//! Absent, the list's default applies. (A negative or fractional number, or one beyond
//! the machine's integers, does not read as a count and is refused when the query is
//! read.)

use crate::error::DomainError;

/// Largest `offset` a list takes: past it the request is refused (400), as the schema
/// says.
pub const MAX_OFFSET: usize = 1_000_000;

/// The offset `given` (default 0), at most [`MAX_OFFSET`].
pub fn offset(given: Option<usize>) -> Result<usize, DomainError> {
    let n = given.unwrap_or(0);
    if n > MAX_OFFSET {
        return Err(DomainError::Invalid(format!(
            "offset: 0 to {MAX_OFFSET}, got {n}"
        )));
    }
    Ok(n)
}

/// The limit `given` for a list of default `default` and maximum `max`.
pub fn limit(given: Option<usize>, default: usize, max: usize) -> Result<usize, DomainError> {
    let n = given.unwrap_or(default);
    if n == 0 || n > max {
        return Err(DomainError::Invalid(format!("limit: 1 to {max}, got {n}")));
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    #[test]
    fn limits_outside_the_range_are_refused_not_clamped() {
        assert_eq!(super::limit(None, 100, 1000).unwrap(), 100);
        assert_eq!(super::limit(Some(1000), 100, 1000).unwrap(), 1000);
        for bad in [0, 1001, 100_000_000] {
            let e = super::limit(Some(bad), 100, 1000).unwrap_err().to_string();
            assert_eq!(e, format!("limit: 1 to 1000, got {bad}"));
        }
    }
}
