//! The stored times ([`rfc3339_millis`]) and this host's clock ([`now_ms`]).

/// Current time as a stored time ([`rfc3339_millis`]).
pub fn now_rfc3339() -> String {
    rfc3339_millis(time::OffsetDateTime::now_utc())
}

/// A time as RFC 3339 UTC with exactly three fraction digits
/// (`2026-11-25T16:10:00.500Z`, truncated to the millisecond), so that the stored times
/// (created, started, finished) sort as text in time order. (The well-known RFC 3339
/// format drops trailing zeros and a zero fraction: `…:00.5Z` sorted after `…:00.12Z`,
/// and `…:00Z` after both.)
pub fn rfc3339_millis(t: time::OffsetDateTime) -> String {
    const MILLIS_UTC: &[time::format_description::BorrowedFormatItem<'_>] = time::macros::format_description!(
        "[year]-[month]-[day]T[hour]:[minute]:[second].[subsecond digits:3]Z"
    );
    t.to_offset(time::UtcOffset::UTC)
        .format(MILLIS_UTC)
        .unwrap_or_default()
}

/// This host's time in milliseconds since the Unix epoch (plus the skew a test may set,
/// [`crate::testing::skew_host_clock`]). The queue's leases and the sessions' expiry do not use
/// it: they are kept by the database's clock, the one clock every host shares.
pub fn now_ms() -> i64 {
    (time::OffsetDateTime::now_utc().unix_timestamp_nanos() / 1_000_000) as i64
        + crate::testing::HOST_CLOCK_SKEW_MS.load(std::sync::atomic::Ordering::Relaxed)
}

#[cfg(test)]
mod time_tests {
    use time::macros::datetime;

    /// Hand-written times: a zero fraction, trailing zeros and a non-UTC offset keep the
    /// fixed width, and the text order is the time order.
    #[test]
    fn stored_times_have_a_fixed_width_and_sort_as_text() {
        let times = [
            datetime!(2026-11-25 16:10:00 UTC),
            datetime!(2026-11-25 16:10:00.12 UTC),
            datetime!(2026-11-25 16:10:00.5 UTC),
            datetime!(2026-11-25 18:10:00.5009 +02:00),
            datetime!(2026-11-25 16:10:01 UTC),
        ];
        let text: Vec<String> = times.iter().map(|t| super::rfc3339_millis(*t)).collect();
        assert_eq!(
            text,
            [
                "2026-11-25T16:10:00.000Z",
                "2026-11-25T16:10:00.120Z",
                "2026-11-25T16:10:00.500Z",
                "2026-11-25T16:10:00.500Z",
                "2026-11-25T16:10:01.000Z",
            ]
        );
        assert!(text.windows(2).all(|w| w[0] <= w[1]), "{text:?}");
        let now = super::now_rfc3339();
        assert_eq!(now.len(), 24, "{now}");
        time::OffsetDateTime::parse(&now, &time::format_description::well_known::Rfc3339).unwrap();
    }
}
