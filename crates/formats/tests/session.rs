//! Session reader (datasets contract, section 1): one test per rule with a bad file,
//! asserting file, line, column and rule; plus gzip, limits and the writer round trip.

use crate::common::{check, gzip};
use mtcal_formats::session::{read_plane_csv, write_plane_csv};
use mtcal_formats::{FormatError, Limits, read_session_dir, read_session_files, write_session_dir};
use mtcal_solver::session::{PlaneRecord, Run, Session, TestKind};
use mtcal_solver::{Axis, Plane, Topology};
use std::collections::BTreeMap;

const JSON: &str = r#"{
  "machine_id": "VMC-0042",
  "measured_at": "2026-11-02T08:30:00Z",
  "topology": {"workpiece": ["X", "Y"], "tool": ["Z"]},
  "temperature_c": 20.4,
  "notes": "free text",
  "planes": [
    {"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, -100], "mounting": "xy-1"},
    {"file": "xz.csv", "plane": "XZ", "head_offset_mm": [0, 0, -100]}
  ]
}"#;

const CSV: &str = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,0.2\n1,0.1,1,0,0,0.2,0.3\n2,0.2,0,0,0,0.0,0.0\n";

fn files(entries: &[(&str, &[u8])]) -> BTreeMap<String, Vec<u8>> {
    entries
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_vec()))
        .collect()
}

fn read(json: &str, xy: &str) -> Result<Session, FormatError> {
    read_session_files(
        json.as_bytes(),
        &files(&[("xy.csv", xy.as_bytes()), ("xz.csv", CSV.as_bytes())]),
        &Limits::default(),
    )
}

/// Reads a session whose xy.csv is `csv` and expects an error there.
fn csv_err(csv: &str) -> FormatError {
    read(JSON, csv).expect_err("the file must be rejected")
}

fn json_err(json: &str) -> FormatError {
    read(json, CSV).expect_err("the session.json must be rejected")
}

#[test]
fn reads_a_valid_session() {
    let s = read(JSON, CSV).unwrap();
    assert_eq!(s.machine_id, "VMC-0042");
    assert_eq!(s.measured_at, "2026-11-02T08:30:00Z");
    assert_eq!(s.topology, Some(Topology::default()));
    assert_eq!(s.conditions.temperature_c, Some(20.4));
    assert_eq!(s.conditions.temperature_source.as_deref(), Some("stated"));
    assert_eq!(s.notes.as_deref(), Some("free text"));
    assert_eq!(s.planes.len(), 2);
    let xy = &s.planes[0];
    assert_eq!(
        (xy.file.as_str(), xy.plane, xy.mounting.as_str()),
        ("xy.csv", Plane::XY, "xy-1")
    );
    assert_eq!(xy.head_offset_mm, [0.0, 0.0, -100.0]);
    // Default mounting: one per file (the file's own name).
    assert_eq!(s.planes[1].mounting, "xz.csv");
    assert_eq!(xy.runs.len(), 2);
    let r = &xy.runs[0];
    assert_eq!(r.number, 1);
    assert_eq!(r.t_s, vec![0.0, 0.1]);
    assert_eq!(r.pos_mm, vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    assert_eq!(r.du_um, vec![0.1, 0.2]);
    assert_eq!(r.dv_um, vec![0.2, 0.3]);
    assert_eq!(r.temp_c, None);
    assert_eq!(r.test, None);
    assert_eq!(r.test_kind(Plane::XY), TestKind::LineX);
    assert_eq!(s.sample_count(), 6);
}

#[test]
fn column_order_free_comments_x_columns_optional_columns() {
    let csv = "# exported by encoder v2\n# second comment\n\
               x-note,dv_um,du_um,z_mm,y_mm,x_mm,t_s,run,temp_c,test\n\
               # comment after the header\n\
               hello,0.2,0.1,0,0,0,0,1,20.5,line_X\n\
               \n\
               ,0.3,0.2,0,0,1,0.1,1,20.6,line_X\n\
               # trailing comment\n";
    let s = read(JSON, csv).unwrap();
    let r = &s.planes[0].runs[0];
    assert_eq!(r.du_um, vec![0.1, 0.2]);
    assert_eq!(r.dv_um, vec![0.2, 0.3]);
    assert_eq!(r.temp_c, Some(vec![20.5, 20.6]));
    assert_eq!(r.test, Some(TestKind::LineX));
}

#[test]
fn time_restarts_are_allowed_between_runs_and_runs_may_resume() {
    let csv = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,5,0,0,0,0,0\n2,1,0,0,0,0,0\n1,6,0,0,0,0,0\n";
    let s = read(JSON, csv).unwrap();
    let runs = &s.planes[0].runs;
    assert_eq!(runs.len(), 2);
    assert_eq!((runs[0].number, runs[0].t_s.clone()), (1, vec![5.0, 6.0]));
    assert_eq!((runs[1].number, runs[1].t_s.clone()), (2, vec![1.0]));
}

// ---- session.json rules -------------------------------------------------------------

#[test]
fn json_syntax_error_names_the_line() {
    let e = json_err("{\n  \"machine_id\": \"M\",\n  \"planes\": [,]\n}");
    check(&e, "session.json", 3, "", "invalid JSON");
}

#[test]
fn json_root_must_be_an_object() {
    check(
        &json_err("[1, 2]"),
        "session.json",
        1,
        "",
        "must be a JSON object",
    );
}

#[test]
fn json_required_fields() {
    let e = json_err(&JSON.replace("\"machine_id\": \"VMC-0042\",", ""));
    check(
        &e,
        "session.json",
        1,
        "machine_id",
        "required field is missing",
    );
    let e = json_err(&JSON.replace("\"measured_at\": \"2026-11-02T08:30:00Z\",", ""));
    check(
        &e,
        "session.json",
        1,
        "measured_at",
        "required field is missing",
    );
    let e = json_err(&JSON.replace("\"machine_id\": \"VMC-0042\"", "\"machine_id\": \"  \""));
    check(&e, "session.json", 2, "machine_id", "must not be empty");
    let e = json_err(&JSON.replace("\"machine_id\": \"VMC-0042\"", "\"machine_id\": 42"));
    check(&e, "session.json", 2, "machine_id", "must be a string");
    let e = json_err(r#"{"machine_id": "M", "measured_at": "2026-11-02T08:30:00Z"}"#);
    check(&e, "session.json", 1, "planes", "required field is missing");
    let e = json_err(&JSON.replace(r#""file": "xy.csv", "#, ""));
    check(
        &e,
        "session.json",
        8,
        "planes[0].file",
        "required field is missing",
    );
    let e = json_err(&JSON.replace(r#""plane": "XZ", "#, ""));
    check(
        &e,
        "session.json",
        9,
        "planes[1].plane",
        "required field is missing",
    );
    let e = json_err(&JSON.replace(r#", "head_offset_mm": [0, 0, -100]}"#, "}"));
    check(
        &e,
        "session.json",
        9,
        "planes[1].head_offset_mm",
        "required field is missing",
    );
}

#[test]
fn json_measured_at_must_be_rfc3339() {
    let e = json_err(&JSON.replace("2026-11-02T08:30:00Z", "02/11/2026 08:30"));
    check(
        &e,
        "session.json",
        3,
        "measured_at",
        "is not an RFC 3339 time stamp",
    );
}

#[test]
fn json_unknown_fields_rejected_unless_x_prefixed() {
    let e = json_err(&JSON.replace("\"notes\"", "\"note\""));
    check(&e, "session.json", 6, "note", "unknown field");
    let e = json_err(&JSON.replace("\"mounting\": \"xy-1\"", "\"mount\": \"xy-1\""));
    check(&e, "session.json", 8, "planes[0].mount", "unknown field");
    let e = json_err(&JSON.replace("\"tool\": [\"Z\"]", "\"tool\": [\"Z\"], \"spindle\": 1"));
    check(&e, "session.json", 4, "topology.spindle", "unknown field");
    // x- fields are accepted anywhere and ignored.
    let ok = JSON
        .replace("\"notes\"", "\"x-operator\": {\"name\": \"A\"}, \"notes\"")
        .replace(
            "\"mounting\": \"xy-1\"",
            "\"mounting\": \"xy-1\", \"x-plate\": \"G123\"",
        );
    assert!(read(&ok, CSV).is_ok());
}

#[test]
fn json_plane_must_be_xy_xz_or_yz() {
    let e = json_err(&JSON.replace("\"plane\": \"XZ\"", "\"plane\": \"ZX\""));
    check(
        &e,
        "session.json",
        9,
        "planes[1].plane",
        "is not a plane (XY, XZ or YZ)",
    );
}

#[test]
fn json_head_offset_must_be_three_finite_numbers() {
    let e = json_err(&JSON.replace("[0, 0, -100], \"mounting\"", "[0, -100], \"mounting\""));
    check(
        &e,
        "session.json",
        8,
        "planes[0].head_offset_mm",
        "array of three finite numbers",
    );
    let e = json_err(&JSON.replace(
        "[0, 0, -100], \"mounting\"",
        "[0, \"a\", -100], \"mounting\"",
    ));
    check(
        &e,
        "session.json",
        8,
        "planes[0].head_offset_mm",
        "three finite numbers",
    );
    // 1e999 is not a finite f64: serde_json refuses it as a syntax-level error.
    let e = json_err(&JSON.replace("[0, 0, -100], \"mounting\"", "[0, 0, 1e999], \"mounting\""));
    check(&e, "session.json", 8, "", "invalid JSON");
    // A finite but absurd offset is refused at its field, as a position cell is: such a
    // number made every figure of its result overflow (nothing stored that cannot be
    // read back).
    for big in ["1e308", "1e20", "1e10", "100001"] {
        let e = json_err(&JSON.replace(
            "[0, 0, -100], \"mounting\"",
            &format!("[{big}, 0, -100], \"mounting\""),
        ));
        check(
            &e,
            "session.json",
            8,
            "planes[0].head_offset_mm",
            "is beyond the plausible position (mm) of ±100000 (micrometres where millimetres",
        );
    }
}

#[test]
fn json_stated_numbers_are_bounded_as_csv_cells_are() {
    for (from, to, field, rule) in [
        (
            "\"temperature_c\": 20.4",
            "\"temperature_c\": 5000",
            "temperature_c",
            "beyond the plausible temperature (°C) of ±1000",
        ),
        (
            "\"temperature_c\": 20.4",
            "\"temperature_c\": -1e300",
            "temperature_c",
            "beyond the plausible temperature (°C) of ±1000",
        ),
    ] {
        let e = json_err(&JSON.replace(from, to));
        assert_eq!(e.column, field, "{e}");
        assert!(e.rule.contains(rule), "{e}");
    }
    let s = read(
        &JSON.replace("\"temperature_c\": 20.4", "\"temperature_c\": 999.5"),
        CSV,
    );
    assert_eq!(s.unwrap().conditions.temperature_c, Some(999.5));
}

#[test]
fn json_topology_must_be_valid() {
    let e = json_err(&JSON.replace("\"tool\": [\"Z\"]", "\"tool\": [\"X\"]"));
    check(&e, "session.json", 4, "topology", "exactly once");
    let e = json_err(&JSON.replace("\"tool\": [\"Z\"]", "\"tool\": [\"W\"]"));
    check(
        &e,
        "session.json",
        4,
        "topology.tool",
        "is not an axis name",
    );
    let e = json_err(&JSON.replace("\"tool\": [\"Z\"]", "\"tool\": \"Z\""));
    check(
        &e,
        "session.json",
        4,
        "topology.tool",
        "must be an array of axis names",
    );
    // Topology is optional.
    let ok = JSON.replace(
        "\"topology\": {\"workpiece\": [\"X\", \"Y\"], \"tool\": [\"Z\"]},",
        "",
    );
    assert_eq!(read(&ok, CSV).unwrap().topology, None);
}

#[test]
fn json_temperature_must_be_a_number() {
    let e = json_err(&JSON.replace("20.4", "\"warm\""));
    check(
        &e,
        "session.json",
        5,
        "temperature_c",
        "must be a finite number",
    );
}

#[test]
fn json_optional_strings_must_be_strings() {
    let e = json_err(&JSON.replace("\"free text\"", "[\"free\"]"));
    check(&e, "session.json", 6, "notes", "must be a string");
    let e = json_err(&JSON.replace("\"mounting\": \"xy-1\"", "\"mounting\": \"\""));
    check(
        &e,
        "session.json",
        8,
        "planes[0].mounting",
        "must not be empty",
    );
}

#[test]
fn utf8_byte_order_mark_is_skipped() {
    let json = format!("\u{feff}{JSON}");
    let csv = format!("\u{feff}{CSV}");
    assert_eq!(read(&json, &csv).unwrap(), read(JSON, CSV).unwrap());
}

#[test]
fn json_planes_must_be_a_non_empty_array() {
    let e = json_err(r#"{"machine_id": "M", "measured_at": "2026-11-02T08:30:00Z", "planes": []}"#);
    check(&e, "session.json", 1, "planes", "at least one plane");
    let e = json_err(r#"{"machine_id": "M", "measured_at": "2026-11-02T08:30:00Z", "planes": {}}"#);
    check(&e, "session.json", 1, "planes", "must be an array");
}

#[test]
fn json_duplicate_file_rejected() {
    let e = json_err(&JSON.replace("\"file\": \"xz.csv\"", "\"file\": \"xy.csv\""));
    check(&e, "session.json", 9, "planes[1].file", "is listed twice");
}

#[test]
fn json_file_must_be_a_plain_name() {
    for bad in ["../xz.csv", "sub/xz.csv", "C:\\\\xz.csv", "session.json"] {
        let e = json_err(&JSON.replace("\"file\": \"xz.csv\"", &format!("\"file\": \"{bad}\"")));
        check(
            &e,
            "session.json",
            9,
            "planes[1].file",
            "not a plain file name",
        );
    }
}

#[test]
fn json_shared_mounting_must_share_the_plane() {
    let json = JSON.replace(
        "\"head_offset_mm\": [0, 0, -100]}",
        "\"head_offset_mm\": [0, 0, -100], \"mounting\": \"xy-1\"}",
    );
    let e = json_err(&json);
    check(
        &e,
        "session.json",
        9,
        "planes[1].mounting",
        "must share the plane",
    );
}

#[test]
fn referenced_file_must_exist() {
    let e = read_session_files(
        JSON.as_bytes(),
        &files(&[("xy.csv", CSV.as_bytes())]),
        &Limits::default(),
    )
    .unwrap_err();
    check(
        &e,
        "session.json",
        9,
        "planes[1].file",
        "`xz.csv` is missing",
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("session.json"), JSON).unwrap();
    std::fs::write(dir.path().join("xy.csv"), CSV).unwrap();
    let e = read_session_dir(dir.path(), &Limits::default()).unwrap_err();
    check(
        &e,
        "session.json",
        9,
        "planes[1].file",
        "`xz.csv` is missing",
    );
    let empty = tempfile::tempdir().unwrap();
    let e = read_session_dir(empty.path(), &Limits::default()).unwrap_err();
    check(&e, "session.json", 0, "", "missing from the folder");
}

#[test]
fn unreferenced_upload_rejected() {
    let e = read_session_files(
        JSON.as_bytes(),
        &files(&[
            ("xy.csv", CSV.as_bytes()),
            ("xz.csv", CSV.as_bytes()),
            ("yz.csv", CSV.as_bytes()),
        ]),
        &Limits::default(),
    )
    .unwrap_err();
    check(&e, "yz.csv", 0, "", "not referenced by session.json");
    // The description itself may travel with the files.
    let with_json = files(&[
        ("session.json", JSON.as_bytes()),
        ("xy.csv", CSV.as_bytes()),
        ("xz.csv", CSV.as_bytes()),
    ]);
    assert!(read_session_files(JSON.as_bytes(), &with_json, &Limits::default()).is_ok());
}

// ---- plane CSV rules ----------------------------------------------------------------

#[test]
fn csv_must_be_utf8() {
    let mut bytes = CSV.as_bytes().to_vec();
    bytes.splice(40..40, [0xff, 0xfe]);
    let e = read_session_files(
        JSON.as_bytes(),
        &files(&[("xy.csv", &bytes), ("xz.csv", CSV.as_bytes())]),
        &Limits::default(),
    )
    .unwrap_err();
    check(&e, "xy.csv", 2, "", "not valid UTF-8");
}

#[test]
fn csv_header_required() {
    check(&csv_err(""), "xy.csv", 1, "", "header required");
    check(
        &csv_err("# only\n# comments\n"),
        "xy.csv",
        3,
        "",
        "header required",
    );
}

#[test]
fn csv_header_without_samples_rejected() {
    let e = csv_err("# c\nrun,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n# nothing\n");
    check(&e, "xy.csv", 2, "", "no samples");
}

#[test]
fn csv_unknown_column_rejected_unless_x_prefixed() {
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,dw_um\n1,0,0,0,0,0,0,0\n");
    check(&e, "xy.csv", 1, "dw_um", "unknown column");
    assert!(
        read(
            JSON,
            "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,x-dw_um\n1,0,0,0,0,0,0,0\n"
        )
        .is_ok()
    );
}

#[test]
fn csv_required_column_missing() {
    let e = csv_err("# c\nrun,t_s,x_mm,y_mm,du_um,dv_um\n1,0,0,0,0,0\n");
    check(&e, "xy.csv", 2, "z_mm", "required column is missing");
}

#[test]
fn csv_duplicate_or_empty_column_names() {
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,t_s\n");
    check(&e, "xy.csv", 1, "t_s", "duplicate column name");
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,,dv_um\n");
    check(&e, "xy.csv", 1, "", "empty column name (column 7)");
}

#[test]
fn csv_field_count_must_match_header() {
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0,0,0,0,0,0\n1,0.1,0,0,0,0\n");
    check(
        &e,
        "xy.csv",
        3,
        "",
        "row has 6 fields but the header has 7 columns",
    );
}

#[test]
fn csv_numbers_must_be_finite_decimals() {
    let row = |cell: &str| {
        format!("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n# c\n1,0,0,0,0,0,0\n1,0.1,0,{cell},0,0,0\n")
    };
    check(
        &csv_err(&row("NaN")),
        "xy.csv",
        4,
        "y_mm",
        "must be finite (no NaN or infinity)",
    );
    check(
        &csv_err(&row("-inf")),
        "xy.csv",
        4,
        "y_mm",
        "must be finite (no NaN or infinity)",
    );
    check(&csv_err(&row("1e400")), "xy.csv", 4, "y_mm", "overflows");
    check(&csv_err(&row("")), "xy.csv", 4, "y_mm", "empty cell");
    check(&csv_err(&row("1,5")), "xy.csv", 4, "", "row has 8 fields");
    check(
        &csv_err(&row("12mm")),
        "xy.csv",
        4,
        "y_mm",
        "`12mm` is not a decimal number",
    );
    // Exponents, signs and surrounding spaces are fine.
    assert!(read(JSON, &row(" -1.5e-3 ")).is_ok());
}

#[test]
fn csv_run_must_be_an_integer() {
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1.5,0,0,0,0,0,0\n");
    check(&e, "xy.csv", 2, "run", "`1.5` is not an integer");
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n,0,0,0,0,0,0\n");
    check(&e, "xy.csv", 2, "run", "empty cell: an integer is required");
}

#[test]
fn csv_time_strictly_increasing_within_a_run() {
    let e = csv_err(
        "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0,0,0,0,0,0\n1,0.1,0,0,0,0,0\n1,0.1,0,0,0,0,0\n",
    );
    check(
        &e,
        "xy.csv",
        4,
        "t_s",
        "strictly increasing within run 1: 0.1 follows 0.1",
    );
}

#[test]
fn csv_test_values_from_the_list_and_constant_within_a_run() {
    let e = csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n1,0,0,0,0,0,0,line_x\n");
    check(&e, "xy.csv", 2, "test", "`line_x` is not a test kind");
    let e = csv_err(
        "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n1,0,0,0,0,0,0,line_X\n1,1,0,0,0,0,0,circle_cw\n",
    );
    check(
        &e,
        "xy.csv",
        3,
        "test",
        "changes within run 1: `circle_cw` after `line_X`",
    );
    let e =
        csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n1,0,0,0,0,0,0,\n1,1,0,0,0,0,0,free\n");
    check(&e, "xy.csv", 3, "test", "`free` after `(empty)`");
    // Empty labels throughout a run mean "infer".
    let s = read(
        JSON,
        "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n1,0,0,0,0,0,0,\n2,1,0,0,0,0,0,free\n",
    )
    .unwrap();
    assert_eq!(s.planes[0].runs[0].test, None);
    assert_eq!(s.planes[0].runs[1].test, Some(TestKind::Free));
}

#[test]
fn csv_optional_temperature_must_be_finite_when_present() {
    let e =
        csv_err("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,temp_c\n1,0,0,0,0,0,0,20\n1,1,0,0,0,0,0,\n");
    check(&e, "xy.csv", 3, "temp_c", "empty cell");
}

#[test]
fn csv_crlf_and_quoted_fields() {
    let csv =
        "\"run\",t_s,x_mm,y_mm,z_mm,du_um,dv_um\r\n# c\r\n1,0,0,0,0,0,0\r\n1,\"0\",0,0,0,0,0\r\n";
    let e = csv_err(csv);
    check(&e, "xy.csv", 4, "t_s", "strictly increasing");
}

#[test]
fn line_numbers_count_newlines_inside_quoted_fields() {
    let csv = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,x-note\n1,0,0,0,0,0,0,\"two\nlines\"\n1,1,0,0,0,0,oops,\n";
    check(
        &csv_err(csv),
        "xy.csv",
        4,
        "dv_um",
        "`oops` is not a decimal number",
    );
}

#[test]
fn sample_limit() {
    let limits = Limits {
        max_samples_per_file: 2,
        ..Limits::default()
    };
    let csv =
        "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0,0,0,0,0,0\n1,1,0,0,0,0,0\n# c\n1,2,0,0,0,0,0\n";
    let e = read_plane_csv("xy.csv", csv.as_bytes(), &limits).unwrap_err();
    check(&e, "xy.csv", 5, "", "exceeds the limit of 2 samples");
    assert_eq!(
        read_plane_csv(
            "xy.csv",
            CSV.as_bytes(),
            &Limits {
                max_samples_per_file: 3,
                ..limits
            }
        )
        .unwrap()
        .len(),
        2
    );
}

#[test]
fn byte_limit_applies_to_the_upload_and_to_decompressed_data() {
    let total = JSON.len() + 2 * CSV.len();
    let tight = Limits {
        max_bytes: total - 1,
        ..Limits::default()
    };
    let all = files(&[("xy.csv", CSV.as_bytes()), ("xz.csv", CSV.as_bytes())]);
    let e = read_session_files(JSON.as_bytes(), &all, &tight).unwrap_err();
    check(&e, "xz.csv", 0, "", "exceeds the byte limit");
    assert!(
        read_session_files(
            JSON.as_bytes(),
            &all,
            &Limits {
                max_bytes: total,
                ..tight
            }
        )
        .is_ok()
    );
    // A gzip bomb: 1 MB of zeros compresses to ~1 kB but exceeds 100 kB decompressed.
    let bomb = gzip(&vec![b'0'; 1_000_000]);
    let e = read_session_files(
        JSON.as_bytes(),
        &files(&[("xy.csv", &bomb), ("xz.csv", CSV.as_bytes())]),
        &Limits {
            max_bytes: 100_000,
            ..Limits::default()
        },
    )
    .unwrap_err();
    check(&e, "xy.csv", 0, "", "exceeds the byte limit");
}

#[test]
fn gzip_by_name_and_by_magic_bytes() {
    let json = JSON.replace("\"xy.csv\"", "\"xy.csv.gz\"");
    let s = read_session_files(
        json.as_bytes(),
        &files(&[
            ("xy.csv.gz", &gzip(CSV.as_bytes())),
            ("xz.csv", &gzip(CSV.as_bytes())),
        ]),
        &Limits::default(),
    )
    .unwrap();
    assert_eq!(s, {
        let mut plain = read(JSON, CSV).unwrap();
        plain.planes[0].file = "xy.csv.gz".into();
        plain
    });
    // A .gz name whose content is not gzip.
    let e = read_session_files(
        json.as_bytes(),
        &files(&[("xy.csv.gz", CSV.as_bytes()), ("xz.csv", CSV.as_bytes())]),
        &Limits::default(),
    )
    .unwrap_err();
    check(&e, "xy.csv.gz", 0, "", "content is not gzip");
    // Corrupt gzip.
    let mut bad = gzip(CSV.as_bytes());
    bad.truncate(bad.len() / 2);
    let e = read_session_files(
        json.as_bytes(),
        &files(&[("xy.csv.gz", &bad), ("xz.csv", CSV.as_bytes())]),
        &Limits::default(),
    )
    .unwrap_err();
    check(&e, "xy.csv.gz", 0, "", "invalid gzip data");
    // Errors inside a gzip file still name its lines.
    let e = read_session_files(
        json.as_bytes(),
        &files(&[
            ("xy.csv.gz", &gzip(b"run,t_s\n")),
            ("xz.csv", CSV.as_bytes()),
        ]),
        &Limits::default(),
    )
    .unwrap_err();
    check(&e, "xy.csv.gz", 1, "x_mm", "required column is missing");
}

// ---- writer ---------------------------------------------------------------------------

fn sample_session() -> Session {
    let run = |number: i64, t0: f64, test: Option<TestKind>, temp: bool| {
        let n = 50;
        Run {
            number,
            test,
            t_s: (0..n).map(|i| t0 + 0.013 * i as f64).collect(),
            pos_mm: (0..n)
                .map(|i| [0.1 * i as f64 - 2.5, 1.0 / 3.0, -7.25e-3 * i as f64])
                .collect(),
            du_um: (0..n)
                .map(|i| (i as f64 * 0.7).sin() * 1.234_567_891)
                .collect(),
            // Tiny values (written with an exponent) between ordinary ones: a column of
            // only tiny values would be refused as millimetres in a micrometre column.
            dv_um: (0..n)
                .map(|i| (i as f64 * 0.3).cos() * if i % 2 == 0 { 1e-7 } else { 2.5 })
                .collect(),
            temp_c: temp.then(|| (0..n).map(|i| 20.0 + 1e-3 * i as f64).collect()),
        }
    };
    Session {
        machine_id: "SIM-1".into(),
        measured_at: "2026-11-23T05:00:00.5+01:00".into(),
        topology: Some(Topology {
            workpiece: vec![Axis::Y],
            tool: vec![Axis::X, Axis::Z],
        }),
        conditions: mtcal_solver::uncertainty::Conditions {
            temperature_c: Some(19.75),
            temperature_source: Some("stated".into()),
            ..Default::default()
        },
        notes: Some("simulated \"quoted\" notes".into()),
        planes: vec![
            PlaneRecord {
                file: "xy.csv".into(),
                plane: Plane::XY,
                head_offset_mm: [0.0, 0.0, -100.0],
                mounting: "m1".into(),
                runs: vec![
                    run(1, 0.0, Some(TestKind::LineX), true),
                    run(2, 10.0, None, true),
                ],
            },
            PlaneRecord {
                file: "yz.csv.gz".into(),
                plane: Plane::YZ,
                head_offset_mm: [40.5, 0.0, -200.0],
                mounting: "yz.csv.gz".into(),
                runs: vec![run(7, 3.0, None, false)],
            },
        ],
    }
}

#[test]
fn write_then_read_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let s = sample_session();
    write_session_dir(dir.path(), &s).unwrap();
    let back = read_session_dir(dir.path(), &Limits::default()).unwrap();
    assert_eq!(back, s);
    let text = std::fs::read_to_string(dir.path().join("xy.csv")).unwrap();
    assert!(
        text.starts_with("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,temp_c,test\n1,0,"),
        "{text}"
    );
    // The second run has no label: empty cells, read back as "infer".
    assert!(text.lines().nth(51).unwrap().ends_with(','), "{text}");
    // The gzip file is really compressed.
    let raw = std::fs::read(dir.path().join("yz.csv.gz")).unwrap();
    assert_eq!(&raw[..2], &[0x1f, 0x8b]);
}

#[test]
fn dir_reader_falls_back_to_gz() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("session.json"), JSON).unwrap();
    std::fs::write(dir.path().join("xy.csv"), CSV).unwrap();
    std::fs::write(dir.path().join("xz.csv.gz"), gzip(CSV.as_bytes())).unwrap();
    let s = read_session_dir(dir.path(), &Limits::default()).unwrap();
    assert_eq!(s, read(JSON, CSV).unwrap());
    // Errors inside the fallback name the file actually read.
    std::fs::write(dir.path().join("xz.csv.gz"), gzip(b"run,t_s\n")).unwrap();
    let e = read_session_dir(dir.path(), &Limits::default()).unwrap_err();
    check(&e, "xz.csv.gz", 1, "x_mm", "required column is missing");
}

#[test]
fn writer_refuses_invalid_sessions_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("out");
    let mut s = sample_session();
    s.planes[0].runs[0].du_um[3] = f64::NAN;
    let e = write_session_dir(&target, &s).unwrap_err();
    assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
    assert!(!target.exists());
    let mut s = sample_session();
    s.planes[1].file = "../escape.csv".into();
    assert!(write_session_dir(&target, &s).is_err());
    let mut s = sample_session();
    s.planes[0].runs[1].temp_c = None;
    assert!(write_plane_csv(Vec::new(), &s.planes[0].runs).is_err());
    let mut s = sample_session();
    s.planes[0].runs[0].t_s[5] = 0.0;
    assert!(write_plane_csv(Vec::new(), &s.planes[0].runs).is_err());
    assert!(!target.exists());
}

/// The plane files are parsed in parallel; the error reported is still the first in the
/// order of the description (xy.csv before xz.csv), and a valid read equals the files
/// read one by one.
#[test]
fn parallel_parse_reports_the_first_bad_file_in_description_order() {
    let bad_xy = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,zz\n";
    let bad_xz = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,yy,0.2\n";
    for _ in 0..20 {
        let e = read_session_files(
            JSON.as_bytes(),
            &files(&[("xy.csv", bad_xy.as_bytes()), ("xz.csv", bad_xz.as_bytes())]),
            &Limits::default(),
        )
        .expect_err("both files are bad");
        assert_eq!(e.file, "xy.csv", "{e}");
        assert_eq!((e.line, e.column.as_str()), (2, "dv_um"), "{e}");
    }
    let s = read(JSON, CSV).unwrap();
    let limits = Limits::default();
    for (plane, name) in s.planes.iter().zip(["xy.csv", "xz.csv"]) {
        let one = read_plane_csv(name, CSV.as_bytes(), &limits).unwrap();
        assert_eq!(plane.runs, one);
    }
}

/// Errors are reported as a read file by file would report them: a plane file that
/// cannot be loaded (corrupt gzip, over the byte limit) counts after the files before it,
/// so a parse error in an earlier file comes first, and a load error before a file that
/// does not parse comes first.
#[test]
fn load_and_parse_errors_come_in_file_order() {
    let bad = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,zz\n";
    let mut corrupt = gzip(CSV.as_bytes());
    corrupt.truncate(corrupt.len() / 2);
    for _ in 0..10 {
        let e = read_session_files(
            JSON.as_bytes(),
            &files(&[("xy.csv", bad.as_bytes()), ("xz.csv", &corrupt)]),
            &Limits::default(),
        )
        .unwrap_err();
        check(&e, "xy.csv", 2, "dv_um", "`zz` is not a decimal number");
        let e = read_session_files(
            JSON.as_bytes(),
            &files(&[("xy.csv", &corrupt), ("xz.csv", bad.as_bytes())]),
            &Limits::default(),
        )
        .unwrap_err();
        check(&e, "xy.csv", 0, "", "invalid gzip data");
        // Over the byte limit at the second file, after a first file that does not parse.
        let tight = Limits {
            max_bytes: JSON.len() + bad.len() + 10,
            ..Limits::default()
        };
        let e = read_session_files(
            JSON.as_bytes(),
            &files(&[("xy.csv", bad.as_bytes()), ("xz.csv", CSV.as_bytes())]),
            &tight,
        )
        .unwrap_err();
        check(&e, "xy.csv", 2, "dv_um", "`zz` is not a decimal number");
    }
}

/// A comment line may end the file without a line break (csv-core's fast reader makes
/// an empty record of it, which the earlier reader refused as a row of 1 field).
#[test]
fn a_comment_may_end_the_file_without_a_line_break() {
    for ending in ["# end", "#", "\r\n# end\r", "\n\n#"] {
        let s = read(JSON, &format!("{CSV}{ending}")).unwrap();
        assert_eq!(s, read(JSON, CSV).unwrap(), "{ending:?}");
    }
    check(
        &csv_err("# only a comment"),
        "xy.csv",
        1,
        "",
        "header required",
    );
}

/// A finite but absurd magnitude (1e308 µm, a position in µm where mm are required) is
/// refused at its cell instead of reaching the solver (where it made every figure NaN);
/// the bounds are the configurable `Limits`.
#[test]
fn implausible_magnitudes_are_refused_at_their_cell() {
    let bad =
        |row: &str| format!("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,0.2\n{row}\n");
    let e = csv_err(&bad("1,0.1,1,0,0,1e308,0.3"));
    check(
        &e,
        "xy.csv",
        3,
        "du_um",
        "plausible deviation (µm) of ±10000",
    );
    let e = csv_err(&bad("1,0.1,250000,0,0,0.2,0.3"));
    check(&e, "xy.csv", 3, "x_mm", "plausible position (mm)");
    let e = csv_err(&bad("1,1e12,1,0,0,0.2,0.3"));
    check(&e, "xy.csv", 3, "t_s", "plausible time (s)");
    // Within a raised limit, the same value is read.
    let limits = Limits {
        max_abs_position_mm: 1e6,
        ..Limits::default()
    };
    // (100 s after the first sample: 2.5 m/s, a speed a machine reaches.)
    let runs = read_plane_csv(
        "xy.csv",
        bad("1,100,250000,0,0,0.2,0.3").as_bytes(),
        &limits,
    )
    .unwrap();
    assert_eq!(runs[0].pos_mm[1][0], 250_000.0);
}

/// A huge cell gives a bounded message: the quote is cut, its length said (a cell just
/// under the line-length limit; a longer line is refused as such).
#[test]
fn a_huge_cell_gives_a_bounded_message() {
    let cell = "z".repeat(60_000);
    let e = csv_err(&format!(
        "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,{cell},0.2\n"
    ));
    let text = e.to_string();
    assert!(text.len() < 1200, "{} bytes", text.len());
    assert!(text.contains("bytes in all"), "{text}");
    assert_eq!((e.line, e.column.as_str()), (2, "du_um"));
}
