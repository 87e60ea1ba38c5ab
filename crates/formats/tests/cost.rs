//! The cost of hostile input stays bounded: the header check is linear in the number of
//! columns, columns per header and bytes per line are capped, and a deadline stops a read
//! (the service sets one per upload). Figures: BENCHMARKS.md, "Rejecting hostile input".

use crate::common::check;
use mtcal_formats::{Limits, read_archive, read_positioning, read_upload};
use std::time::{Duration, Instant};

/// `n` distinct `x-` column names, comma-separated.
fn x_columns(n: usize) -> String {
    (0..n)
        .map(|i| format!("x-{i}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// A header of 200 000 distinct ignored columns, with the caps raised out of the way:
/// the duplicate check compared each name with every earlier one (2·10¹⁰ comparisons,
/// minutes in the debug profile); with a set it is linear and the reader gets to the
/// schema rule at once.
#[test]
fn a_huge_header_is_checked_in_linear_time() {
    let header = format!("axis,run,direction,target_mm,{}\n", x_columns(200_000));
    let raised = Limits {
        max_columns: usize::MAX,
        max_line_bytes: usize::MAX,
        ..Limits::default()
    };
    let e = read_positioning("p.csv", header.as_bytes(), &raised).unwrap_err();
    check(&e, "p.csv", 1, "deviation_um", "required column is missing");
    // A duplicate is still found, at the end of the header.
    let header = format!("{},x-7\n", x_columns(200_000));
    let e = read_positioning("p.csv", header.as_bytes(), &raised).unwrap_err();
    check(&e, "p.csv", 1, "x-7", "duplicate column name");
}

#[test]
fn columns_per_header_are_capped() {
    // The pathological upload: a header-only CSV of 80 000 `x-` columns.
    let header = format!("# a comment\n{}\n", x_columns(80_000));
    let e = read_positioning("p.csv", header.as_bytes(), &Limits::default()).unwrap_err();
    assert!(e.is_limit(), "{e}");
    check(
        &e,
        "p.csv",
        2,
        "",
        "the header has 80000 columns, more than the limit of 1024 (configurable)",
    );
    // The cap is configurable: 1024 columns pass it with the default, 10 do not with 9.
    let ok = format!(
        "axis,run,direction,target_mm,deviation_um,{}\nX,1,+,0,0,{}\n",
        x_columns(1019),
        vec!["0"; 1019].join(",")
    );
    read_positioning("p.csv", ok.as_bytes(), &Limits::default()).unwrap();
    let e = read_positioning(
        "p.csv",
        b"axis,run,direction,target_mm,deviation_um,x-a,x-b,x-c,x-d,x-e\n",
        &Limits {
            max_columns: 9,
            ..Limits::default()
        },
    )
    .unwrap_err();
    assert!(e.is_limit());
    check(&e, "p.csv", 1, "", "the header has 10 columns");
}

#[test]
fn line_length_is_capped_on_the_header_and_on_rows() {
    let long = "x".repeat(70_000);
    let csv = format!("axis,run,direction,target_mm,deviation_um,x-{long}\n");
    let e = read_positioning("p.csv", csv.as_bytes(), &Limits::default()).unwrap_err();
    assert!(e.is_limit(), "{e}");
    check(
        &e,
        "p.csv",
        1,
        "",
        "line is longer than the limit of 65536 bytes (configurable)",
    );
    // A data row: its own line is named.
    let csv = format!(
        "axis,run,direction,target_mm,deviation_um,x-note\nX,1,+,0,0,a\n\nX,1,-,0,0,{long}\n"
    );
    let e = read_positioning("p.csv", csv.as_bytes(), &Limits::default()).unwrap_err();
    check(&e, "p.csv", 4, "", "line is longer than the limit");
    let raised = Limits {
        max_line_bytes: 100_000,
        ..Limits::default()
    };
    assert_eq!(
        read_positioning("p.csv", csv.as_bytes(), &raised)
            .unwrap()
            .records
            .len(),
        2
    );
}

/// A plane file of `rows` samples.
fn plane(rows: usize) -> String {
    let mut s = String::from("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n");
    for i in 0..rows {
        s += &format!("1,{i},{},0,0,0.1,0.2\n", i % 100);
    }
    s
}

const SESSION: &str = r#"{"machine_id": "M", "measured_at": "2026-01-01T00:00:00Z",
 "planes": [{"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, 0]}]}"#;

#[test]
fn a_deadline_stops_a_read_with_a_limit_error() {
    let files = vec![
        ("session.json".to_string(), SESSION.as_bytes().to_vec()),
        ("xy.csv".to_string(), plane(10_000).into_bytes()),
    ];
    assert!(read_upload(&files, &Limits::default()).is_ok());
    let generous = Limits::default().with_time_limit(Duration::from_secs(3600));
    assert!(read_upload(&files, &generous).is_ok());
    let past = Limits {
        deadline: Some(Instant::now()),
        ..Limits::default()
    };
    let e = read_upload(&files, &past).unwrap_err();
    assert!(e.is_limit(), "{e}");
    check(
        &e,
        "xy.csv",
        0,
        "",
        "the time allowed to read this upload ran out",
    );
    // Archives look at it per entry.
    let mut b = tar::Builder::new(Vec::new());
    for (name, bytes) in &files {
        let mut h = tar::Header::new_gnu();
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, name, bytes.as_slice()).unwrap();
    }
    let t = b.into_inner().unwrap();
    assert_eq!(read_archive("s.tar", &t, &generous).unwrap().len(), 2);
    let e = read_archive("s.tar", &t, &past).unwrap_err();
    assert!(e.is_limit());
    check(&e, "s.tar", 0, "", "ran out");
}

/// The deadline is also looked at between rows, so one long file stops too: with a
/// deadline that passes after the file is opened but before its end, the error names the
/// row where the clock was looked at (every 4096 rows: row 4096·k is line 4096·k + 1).
#[test]
fn a_deadline_passing_mid_file_stops_at_a_row() {
    let big = plane(400_000);
    let read = |lim: &Limits| mtcal_formats::session::read_plane_csv("xy.csv", big.as_bytes(), lim);
    // A deadline already past when the file is opened: line 0.
    let past = Limits {
        deadline: Some(Instant::now()),
        ..Limits::default()
    };
    assert_eq!(read(&past).unwrap_err().line, 0);
    // Deadlines from 1 ms up: one of them passes mid-file.
    let mid = (0..12)
        .filter_map(|k| {
            read(&Limits::default().with_time_limit(Duration::from_millis(1 << k))).err()
        })
        .find(|e| e.line > 0)
        .expect("some deadline passes while the file is read");
    assert!(mid.is_limit());
    assert_eq!((mid.line - 1) % 4096, 0, "{mid}");
    check(&mid, "xy.csv", mid.line, "", "ran out");
}
