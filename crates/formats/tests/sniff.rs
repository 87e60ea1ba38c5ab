//! Dataset-kind sniffing from names and headers.

use crate::common::gzip;
use mtcal_formats::{DatasetKind, sniff_kind, sniff_path};

#[test]
fn tells_the_formats_apart() {
    let cases: [(&str, &str, Option<DatasetKind>); 9] = [
        (
            "session.json",
            "{\"machine_id\": \"M\", \"planes\": []}",
            Some(DatasetKind::Session),
        ),
        ("cradle.json", "{\"machine_id\": \"M\"}", None),
        (
            "xy.csv",
            "# c\nrun,t_s,x_mm,y_mm,z_mm,du_um,dv_um,test\n",
            Some(DatasetKind::PlaneCsv),
        ),
        (
            "r.csv",
            "\"a_deg\",c_deg,x_mm,y_mm,z_mm,t_s\n",
            Some(DatasetKind::RotaryPoints),
        ),
        (
            "p.csv",
            "axis,run,direction,target_mm,deviation_um\r\nX,1,+,0,0\r\n",
            Some(DatasetKind::Positioning),
        ),
        (
            "d.csv",
            "t_s,spindle_rpm,ch1_um,t1_c,x-note\n",
            Some(DatasetKind::DriftLog),
        ),
        ("d.csv", "t_s\n", None),
        ("d.csv", "t_s,load_kw\n", None),
        ("e.csv", "", None),
    ];
    for (name, text, kind) in cases {
        assert_eq!(sniff_kind(name, text.as_bytes()), kind, "{name}: {text}");
    }
    let gz = gzip(b"t_s,ch1_um\n0,1\n");
    assert_eq!(sniff_kind("d.csv.gz", &gz), Some(DatasetKind::DriftLog));
}

#[test]
fn sniffs_paths() {
    let heat =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/fl_thermal/heat_run.csv");
    assert_eq!(sniff_path(&heat), Some(DatasetKind::DriftLog));
    let dir = tempfile::tempdir().unwrap();
    assert_eq!(sniff_path(dir.path()), None);
    std::fs::write(dir.path().join("session.json"), "{}").unwrap();
    assert_eq!(sniff_path(dir.path()), Some(DatasetKind::Session));
    assert_eq!(sniff_path(&dir.path().join("missing.csv")), None);
}
