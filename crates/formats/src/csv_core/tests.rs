//! The tests of `csv_core.rs`.

use super::*;

/// csv-core's records of `text` (the reference): the fields of each record, or
/// `Err(fields)` for the first record beyond the column or byte limit, where reading
/// stops. csv-core's NFA, its definition: its faster DFA also makes an empty record
/// of a comment that ends the input without a line break (csv-core 0.1.13:
/// `"1\n# end"` gives the records `1` and an empty one), which the datasets rules
/// (comment lines are skipped) and this reader do not.
fn reference(text: &str, limits: &Limits) -> Vec<Result<Vec<String>, usize>> {
    let mut rdr = csv_core::ReaderBuilder::new()
        .delimiter(limits.csv_dialect.delimiter())
        .comment(Some(b'#'))
        .nfa(true)
        .build();
    let (mut out, mut ends) = (vec![0u8; 1 << 16], vec![0usize; 1 << 12]);
    let mut input = text.as_bytes();
    let mut records = Vec::new();
    // Output and field ends accumulate over the calls that make up one record.
    let (mut nout, mut nends) = (0, 0);
    loop {
        let (res, nin, o, e) = rdr.read_record(input, &mut out[nout..], &mut ends[nends..]);
        input = &input[nin..];
        nout += o;
        nends += e;
        match res {
            csv_core::ReadRecordResult::Record => {
                let over = nends > limits.max_columns || nout + nends > limits.max_line_bytes;
                if over {
                    records.push(Err(nends));
                    return records;
                }
                let mut from = 0;
                let fields = ends[..nends]
                    .iter()
                    .map(|&to| {
                        let f = String::from_utf8(out[from..to].to_vec()).unwrap();
                        from = to;
                        f
                    })
                    .collect();
                records.push(Ok(fields));
                (nout, nends) = (0, 0);
            }
            csv_core::ReadRecordResult::End => return records,
            csv_core::ReadRecordResult::InputEmpty => {}
            r => panic!("reference buffers too small: {r:?}"),
        }
    }
}

/// The reader's records of `text`, in the same form.
fn ours(text: &str, limits: &Limits) -> Vec<Result<Vec<String>, usize>> {
    let mut t = CsvTable::over("t.csv", text, limits);
    let mut records = Vec::new();
    loop {
        match t.read_record() {
            Ok(true) => records.push(Ok((0..t.fields.len())
                .map(|i| t.cell(i).to_string())
                .collect())),
            Ok(false) => return records,
            Err(e) => {
                assert!(e.is_limit(), "{e}");
                // The number of fields, when the column limit was the one exceeded.
                let n = e.rule.split_whitespace().find_map(|w| w.parse().ok());
                let n = if e.rule.contains("columns") && !e.rule.starts_with("line") {
                    n.unwrap()
                } else {
                    t.fields.len().max(1)
                };
                records.push(Err(n));
                return records;
            }
        }
    }
}

/// The one-pass splitter and csv-core give the same records, fields and limit
/// errors on random text made of everything that matters to the split (separators of
/// both dialects, quotes, `\r`, `\n`, `#`, spaces, a two-byte character), under
/// loose and tight limits.
#[test]
fn split_equals_csv_core() {
    let tokens = [
        "a", "1", ",", ",", ";", "\"", "\"", "\n", "\n", "\r", "#", " ", "é",
    ];
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = |n: u64| {
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (x >> 33) % n
    };
    let mut quoted = 0;
    for case in 0..30_000 {
        let len = next(40) as usize;
        let text: String = (0..len)
            .map(|_| tokens[next(tokens.len() as u64) as usize])
            .collect();
        let dialect = if case % 2 == 0 {
            crate::CsvDialect::Plain
        } else {
            crate::CsvDialect::Excel
        };
        let limits = if case % 3 == 0 {
            Limits {
                max_columns: 1 + next(4) as usize,
                max_line_bytes: 1 + next(12) as usize,
                csv_dialect: dialect,
                ..Limits::default()
            }
        } else {
            Limits::default().with_dialect(dialect)
        };
        quoted += usize::from(text.contains('"'));
        let want = reference(&text, &limits);
        let got = ours(&text, &limits);
        // A limit error: the same record refused (its field count when the columns
        // limit is the one broken).
        match (want.last(), got.last()) {
            (Some(Err(a)), Some(Err(b))) if *a > limits.max_columns => {
                assert_eq!(a, b, "{text:?}");
                assert_eq!(want.len(), got.len(), "{text:?}");
            }
            (Some(Err(_)), Some(Err(_))) => assert_eq!(want.len(), got.len(), "{text:?}"),
            _ => assert_eq!(want, got, "{text:?} {limits:?}"),
        }
    }
    assert!(quoted > 10_000, "{quoted}");
}

/// A reproducible generator (LCG) of indices below `n`.
fn lcg(seed: u64) -> impl FnMut(u64) -> u64 {
    let mut x = seed;
    move |n| {
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (x >> 33) % n
    }
}

/// Where `fast_float2::parse_partial` reads a whole cell as a finite number, the
/// standard library reads the same bits: on random decimals of every length (beyond
/// 19 digits, where both fall back from Eisel–Lemire to big decimals), exponents near
/// the ends of the range, halfway cases and the forms the rules name.
#[test]
fn partial_parser_equals_std() {
    let mut cases: Vec<String> = [
        "0",
        "-0",
        "+0",
        "1.",
        "-1.",
        ".5",
        "+.5",
        "-.5",
        "12",
        "1e5",
        "1E+05",
        "1.5e-3",
        "9007199254740993",
        "9007199254740992.5",
        "2.2250738585072011e-308",
        "2.2250738585072014e-308",
        "4.9e-324",
        "2.4703282292062327e-324",
        "1.7976931348623157e308",
        "1.7976931348623159e308",
        "1e23",
        "8.98846567431158e307",
        "0.1",
        "0.30000000000000004",
        "123456789012345678901234567890",
        "0.000000000000000000000000000001",
        "1e400",
        "1e-400",
        "inf",
        "-infinity",
        "NaN",
        "1e",
        "1e+",
        ".",
        "-",
        "+-1",
        "0x10",
        "1_0",
        "1,5",
        " 1",
        "1 ",
        "١",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut next = lcg(0x2545_f491_4f6c_dd1d);
    for _ in 0..200_000 {
        let digits = 1 + next(25) as usize;
        let mut s: String = (0..digits)
            .map(|_| char::from(b'0' + next(10) as u8))
            .collect();
        let dot = next(digits as u64 + 2) as usize;
        if dot <= s.len() {
            s.insert(dot, '.');
        }
        if next(3) == 0 {
            s += &format!("e{}", next(640) as i64 - 330);
        }
        if next(2) == 0 {
            s.insert(0, '-');
        }
        cases.push(s);
    }
    let mut whole = 0;
    for s in &cases {
        if let Ok((v, n)) = fast_float2::parse_partial::<f64, _>(s.as_bytes())
            && n == s.len()
            && v.is_finite()
        {
            whole += 1;
            let std: f64 = s.parse().unwrap_or_else(|_| panic!("std refuses {s:?}"));
            assert_eq!(v.to_bits(), std.to_bits(), "{s}");
        }
    }
    assert!(whole > 190_000, "{whole}");
}

/// A row's values as read: the bits of `a`, the text of `b`, the bits of `c`.
type Row = (u64, String, u64);

/// The outcome of reading `text` with the columns `a` and `c` numbers (a position,
/// a deviation) and `b` text, asked for in the order a plane reader asks (c, then
/// b, then a): per row the values' bits and the text, until the first error.
/// The second figure counts the rows the scan accepted.
fn outcome(text: &str, limits: &Limits, scan: bool) -> (Vec<Result<Row, String>>, usize) {
    let mut out = Vec::new();
    let mut scanned = 0;
    let mut t = match CsvTable::open("t.csv", text.as_bytes(), limits) {
        Ok(t) => t,
        Err(e) => return (vec![Err(e.to_string())], 0),
    };
    if scan {
        t.scan(&[(0, Quantity::Position), (2, Quantity::Deviation)]);
    }
    loop {
        let row = t.next_row().and_then(|more| {
            if !more {
                return Ok(None);
            }
            scanned += usize::from(t.scanned);
            let c = t.quantity(2, Quantity::Deviation)?;
            let b = t.text(1).to_string();
            let a = t.quantity(0, Quantity::Position)?;
            Ok(Some((a.to_bits(), b, c.to_bits())))
        });
        match row {
            Ok(Some(r)) => out.push(Ok(r)),
            Ok(None) => return (out, scanned),
            Err(e) => {
                out.push(Err(e.to_string()));
                return (out, scanned);
            }
        }
    }
}

/// The one-pass row scan gives the same values and the same errors (file, line,
/// column, rule) as the cell-by-cell path, on random rows of numbers in every form,
/// bad cells (text, empty, quoted, spaced, NaN, overflowing, beyond the bound,
/// decimal commas), missing and extra fields, comments, blank lines and both line
/// ends, in both dialects.
#[test]
fn row_scan_equals_cell_by_cell_reading() {
    let cells = [
        "1",
        "-2.5",
        "+.5",
        "12345.678901234567",
        "0.30000000000000004",
        "1e3",
        "1E-3",
        "99999",
        "100001",
        "20000",
        "1e400",
        "NaN",
        "inf",
        "",
        " 3",
        "4 ",
        "\"5\"",
        "\"6,5\"",
        "7,5",
        "x",
        "1e",
        "--1",
        "0x1",
        "8;",
        "9\"",
        "a#b",
        "é",
        "a label longer than sixteen bytes",
        "3.25 and text longer than sixteen bytes",
    ];
    let ends = ["\n", "\n", "\r\n", "\r", "\n\n", "\n# c\n"];
    let mut next = lcg(0x9e37_79b9_7f4a_7c15);
    let (mut rows_scanned, mut rows_read) = (0, 0);
    for case in 0..4_000 {
        let excel = case % 2 == 1;
        let d = if excel { ";" } else { "," };
        let mut text = format!("a{d}b{d}c\n");
        for _ in 0..1 + next(6) {
            let fields = if next(8) == 0 { 2 + next(3) } else { 3 };
            let row: Vec<&str> = (0..fields)
                .map(|_| {
                    if next(3) == 0 {
                        cells[next(cells.len() as u64) as usize]
                    } else {
                        cells[next(6) as usize]
                    }
                })
                .collect();
            text += &row.join(d);
            text += ends[next(ends.len() as u64) as usize];
        }
        if next(4) == 0 {
            text.pop();
        }
        let limits = Limits {
            max_abs_position_mm: 1e5,
            max_abs_deviation_um: 1e4,
            ..Limits::default()
        }
        .with_dialect(if excel {
            crate::CsvDialect::Excel
        } else {
            crate::CsvDialect::Plain
        });
        let (with, scanned) = outcome(&text, &limits, true);
        let (without, none) = outcome(&text, &limits, false);
        assert_eq!(with, without, "{text:?}");
        assert_eq!(none, 0);
        rows_scanned += scanned;
        rows_read += without.len();
    }
    // Both paths are exercised.
    assert!(
        rows_scanned > 1_000 && rows_read > 2 * rows_scanned,
        "{rows_scanned} of {rows_read}"
    );
}
