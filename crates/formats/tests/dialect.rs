//! Spreadsheet (Excel) CSV (docs/datasets.md, "Spreadsheet (Excel) CSV"): in the plain
//! dialect each Excel feature is recognised and the message says what to change; in the
//! Excel dialect the file reads equal to its plain form.

use crate::common::check;
use mtcal_formats::{
    CsvDialect, Limits, read_drift_log, read_positioning, read_rotary_points, read_upload,
};

const BOM: &str = "\u{feff}";
const PLAIN: &str = "axis,run,direction,target_mm,deviation_um\nX,1,+,0,1.25\nX,1,-,100.5,-2.5\n";
/// PLAIN as a spreadsheet in a German or French locale saves it.
const EXCEL: &str =
    "axis;run;direction;target_mm;deviation_um\r\nX;1;+;0;1,25\r\nX;1;-;100,5;-2,5\r\n";

fn excel() -> Limits {
    Limits::default().with_dialect(CsvDialect::Excel)
}

#[test]
fn a_semicolon_header_is_recognised_and_the_change_said() {
    let e = read_positioning("pos.csv", EXCEL.as_bytes(), &Limits::default()).unwrap_err();
    check(
        &e,
        "pos.csv",
        1,
        "",
        "the header is separated by `;`, as a spreadsheet saves CSV in a locale with decimal \
         commas: save the file with `,` separators and `.` decimal points, or have it read in \
         the Excel dialect (`--csv-dialect excel`, or the upload field `csv_dialect=excel`)",
    );
    // Through an upload too: the kind is still recognised from a `;` header.
    let e = read_upload(
        &[("pos.csv".to_string(), EXCEL.as_bytes().to_vec())],
        &Limits::default(),
    )
    .unwrap_err();
    assert!(e.rule.contains("separated by `;`"), "{e}");
}

#[test]
fn a_decimal_comma_is_recognised_and_the_change_said() {
    // A quoted cell keeps its comma as one field.
    let csv = "axis,run,direction,target_mm,deviation_um\nX,1,+,0,\"1,25\"\n";
    let e = read_positioning("pos.csv", csv.as_bytes(), &Limits::default()).unwrap_err();
    check(
        &e,
        "pos.csv",
        2,
        "deviation_um",
        "`1,25` has a decimal comma: write `1.25` (`.` is the decimal point), or have the \
         file read in the Excel dialect",
    );
}

#[test]
fn a_byte_order_mark_is_read_and_named_with_an_excel_header() {
    // Alone it changes nothing: the file is read.
    let with_bom = format!("{BOM}{PLAIN}");
    let runs = read_positioning("pos.csv", with_bom.as_bytes(), &Limits::default()).unwrap();
    assert_eq!(runs.records.len(), 2);
    // With a `;` header the message says the mark is fine and the separators are not.
    let e = read_positioning(
        "pos.csv",
        format!("{BOM}{EXCEL}").as_bytes(),
        &Limits::default(),
    )
    .unwrap_err();
    check(
        &e,
        "pos.csv",
        1,
        "",
        "(its UTF-8 byte-order mark, also written by spreadsheets, is fine in either dialect)",
    );
}

#[test]
fn a_plain_file_read_in_the_excel_dialect_says_so() {
    let e = read_positioning("pos.csv", PLAIN.as_bytes(), &excel()).unwrap_err();
    check(
        &e,
        "pos.csv",
        1,
        "",
        "the header is separated by `,` but the file is read in the Excel dialect",
    );
}

/// Every CSV format: the Excel form (BOM, `;`, decimal commas, CRLF) read in the Excel
/// dialect equals the plain form read in the plain dialect.
#[test]
fn excel_files_read_in_the_excel_dialect_equal_the_plain_ones() {
    let to_excel = |plain: &str| format!("{BOM}{}", plain.replace(',', ";").replace('.', ","));
    let plain_lim = Limits::default();
    assert_eq!(
        read_positioning("p.csv", to_excel(PLAIN).as_bytes(), &excel()).unwrap(),
        read_positioning("p.csv", PLAIN.as_bytes(), &plain_lim).unwrap()
    );
    assert_eq!(
        read_positioning("p.csv", EXCEL.as_bytes(), &excel()).unwrap(),
        read_positioning("p.csv", PLAIN.as_bytes(), &plain_lim).unwrap()
    );
    let rotary =
        "a_deg,c_deg,x_mm,y_mm,z_mm,t_s\n0,0,100.125,0,0.5,0.1\n-90,90.5,0,99.75,1.5,0.2\n";
    assert_eq!(
        read_rotary_points("r.csv", to_excel(rotary).as_bytes(), None, &excel()).unwrap(),
        read_rotary_points("r.csv", rotary.as_bytes(), None, &plain_lim).unwrap()
    );
    let drift = "t_s,spindle_um,t1_c\n0,0.5,20.25\n60,1.75,20.5\n120,2.5,20.75\n";
    assert_eq!(
        read_drift_log("d.csv", to_excel(drift).as_bytes(), &excel()).unwrap(),
        read_drift_log("d.csv", drift.as_bytes(), &plain_lim).unwrap()
    );
    // A session: session.json is JSON (no dialect), its plane files are CSV.
    let json = r#"{"machine_id": "M", "measured_at": "2026-01-01T00:00:00Z",
      "planes": [{"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, -100.5]}]}"#;
    let plane = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n1,0,0,0,0,0.125,-0.5,line_X\n\
                 1,0.1,1.5,0,0,0.25,-0.75,line_X\n1,0.2,3,0,0,0.5,-1.25,line_X\n";
    let upload = |csv: String, lim: &Limits| {
        read_upload(
            &[
                ("session.json".to_string(), json.as_bytes().to_vec()),
                ("xy.csv".to_string(), csv.into_bytes()),
            ],
            lim,
        )
        .unwrap()
    };
    let (a, b) = (
        upload(to_excel(plane), &excel()),
        upload(plane.to_string(), &plain_lim),
    );
    assert_eq!(format!("{:?}", a.data), format!("{:?}", b.data));
    assert_eq!(a.samples(), 3);
}
