//! Whole uploads (`read_upload`, `read_path`, `read_archive`): the CLI (paths) and the
//! server (files in memory, archives) must accept and refuse the same inputs, and an
//! archive may hold only plain files and folders.

use crate::common::{check, gzip};
use mtcal_formats::{DatasetData, FormatError, Limits, read_archive, read_path, read_upload};
use std::path::Path;

pub(crate) const JSON: &str = r#"{
  "machine_id": "VMC-0042",
  "measured_at": "2026-11-02T09:30:00+01:00",
  "planes": [
    {"file": "xy.csv", "plane": "XY", "head_offset_mm": [0, 0, -100]},
    {"file": "xz.csv", "plane": "XZ", "head_offset_mm": [0, 0, -100]}
  ]
}"#;

pub(crate) const CSV: &str = "run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n1,0.0,0,0,0,0.1,0.2\n1,0.1,1,0,0,0.2,0.3\n2,0.2,0,0,0,0.0,0.0\n";
const ROTARY: &str = "a_deg,c_deg,x_mm,y_mm,z_mm\n0,0,100,0,0\n0,90,0,100,0\n";
const SIDECAR: &str = r#"{"machine_id": "5AX-1", "measured_at": "2026-11-02T08:30:00Z"}"#;
pub(crate) const POSITIONING: &str =
    "axis,run,direction,target_mm,deviation_um\nX,1,+,0,0.5\nX,1,+,10,0.7\n";

type Files = Vec<(String, Vec<u8>)>;

fn files(entries: &[(&str, &[u8])]) -> Files {
    entries
        .iter()
        .map(|(n, b)| (n.to_string(), b.to_vec()))
        .collect()
}

fn session_files() -> Files {
    files(&[
        ("session.json", JSON.as_bytes()),
        ("xy.csv", CSV.as_bytes()),
        ("xz.csv", CSV.as_bytes()),
    ])
}

fn write_dir(dir: &Path, files: &Files) {
    for (n, b) in files {
        std::fs::write(dir.join(n), b).unwrap();
    }
}

/// Reads `files` as an upload and as a folder; asserts that both agree and returns the
/// outcome (the error of the upload when both refuse).
fn both(files: &Files) -> Result<mtcal_formats::Dataset, FormatError> {
    let dir = tempfile::tempdir().unwrap();
    write_dir(dir.path(), files);
    let up = read_upload(files, &Limits::default());
    let folder = read_path(dir.path(), &Limits::default());
    match (&up, &folder) {
        (Ok(a), Ok(b)) => {
            assert_eq!((a.kind(), a.samples()), (b.kind(), b.samples()));
            assert_eq!(a.files, b.files);
            assert_eq!(a.ignored, b.ignored);
        }
        (Err(a), Err(b)) => assert_eq!(a, b, "upload and folder refuse differently"),
        _ => panic!("upload {up:?} but folder {folder:?}"),
    }
    up
}

#[test]
fn session_upload_and_folder_read_the_same_session() {
    let d = both(&session_files()).unwrap();
    assert_eq!(d.kind(), "session");
    assert_eq!(d.samples(), 6);
    assert_eq!(d.files, ["session.json", "xy.csv", "xz.csv"]);
    assert_eq!(d.declared_in.as_deref(), Some("session.json"));
    // The declared time, normalised to UTC; the machine checked against the target.
    assert_eq!(
        d.measured_at_utc().unwrap().as_deref(),
        Some("2026-11-02T08:30:00Z")
    );
    d.check_machine("VMC-0042").unwrap();
    let e = d.check_machine("VMC-9").unwrap_err();
    check(
        &e,
        "session.json",
        0,
        "machine_id",
        "does not match the machine \"VMC-9\"",
    );
}

#[test]
fn gzip_description_and_gz_plane_names_are_accepted_by_both() {
    let mut f = session_files();
    f[0] = ("session.json.gz".into(), gzip(JSON.as_bytes()));
    f[1] = ("xy.csv.gz".into(), gzip(CSV.as_bytes()));
    let d = both(&f).unwrap();
    assert_eq!(d.files, ["session.json.gz", "xy.csv.gz", "xz.csv"]);
    let DatasetData::Session(s) = &d.data else {
        panic!()
    };
    // The plane keeps the name session.json gives it.
    assert_eq!(s.planes[0].file, "xy.csv");
    // Both forms of one file.
    let mut twice = session_files();
    twice.push(("xy.csv.gz".into(), gzip(CSV.as_bytes())));
    check(
        &both(&twice).unwrap_err(),
        "xy.csv.gz",
        0,
        "",
        "given twice",
    );
    let mut twice = session_files();
    twice.push(("session.json.gz".into(), gzip(JSON.as_bytes())));
    check(
        &both(&twice).unwrap_err(),
        "session.json.gz",
        0,
        "",
        "given twice",
    );
}

#[test]
fn a_gz_name_with_plain_content_is_refused_by_both() {
    let mut f = session_files();
    f[1] = ("xy.csv.gz".into(), CSV.as_bytes().to_vec());
    check(
        &both(&f).unwrap_err(),
        "xy.csv.gz",
        0,
        "",
        "content is not gzip",
    );
    let mut f = session_files();
    f[0] = ("session.json.gz".into(), JSON.as_bytes().to_vec());
    check(
        &both(&f).unwrap_err(),
        "session.json.gz",
        0,
        "",
        "content is not gzip",
    );
}

#[test]
fn files_beside_a_session_other_than_csv_are_ignored_csv_refused() {
    // A `simulate` folder carries truth.json.
    let mut f = session_files();
    f.push(("truth.json".into(), b"{}".to_vec()));
    f.push(("notes.txt".into(), b"hello".to_vec()));
    let d = both(&f).unwrap();
    assert_eq!(d.ignored, ["notes.txt", "truth.json"]);
    assert_eq!(d.files, ["session.json", "xy.csv", "xz.csv"]);
    // A CSV that session.json does not name is most likely a forgotten plane.
    let mut f = session_files();
    f.push(("yz.csv".into(), CSV.as_bytes().to_vec()));
    check(
        &both(&f).unwrap_err(),
        "yz.csv",
        0,
        "",
        "not referenced by session.json",
    );
    // A missing plane names both names looked for.
    let f = files(&[
        ("session.json", JSON.as_bytes()),
        ("xy.csv", CSV.as_bytes()),
    ]);
    check(
        &both(&f).unwrap_err(),
        "session.json",
        6,
        "planes[1].file",
        "`xz.csv` is missing (looked for `xz.csv` and `xz.csv.gz`)",
    );
}

#[test]
fn file_names_read_must_be_plain() {
    let json = JSON.replace("xy.csv", "x y.csv");
    let f = files(&[
        ("session.json", json.as_bytes()),
        ("x y.csv", CSV.as_bytes()),
        ("xz.csv", CSV.as_bytes()),
    ]);
    check(
        &both(&f).unwrap_err(),
        "x y.csv",
        0,
        "",
        "only letters, digits",
    );
    // An ignored file may have any name: it is neither read nor stored.
    let mut f = session_files();
    f.push(("read me (1).txt".into(), b"x".to_vec()));
    assert_eq!(both(&f).unwrap().ignored, ["read me (1).txt"]);
}

#[test]
fn single_file_kinds_and_the_rotary_sidecar() {
    let d = both(&files(&[
        ("cradle.csv", ROTARY.as_bytes()),
        ("cradle.json", SIDECAR.as_bytes()),
    ]))
    .unwrap();
    assert_eq!((d.kind(), d.samples()), ("rotary_points", 2));
    assert_eq!(d.declared_in.as_deref(), Some("cradle.json"));
    let e = d.check_machine("other").unwrap_err();
    check(&e, "cradle.json", 0, "machine_id", "does not match");
    // A gzip sidecar.
    let d = read_upload(
        &files(&[
            ("cradle.csv", ROTARY.as_bytes()),
            ("cradle.json.gz", &gzip(SIDECAR.as_bytes())),
        ]),
        &Limits::default(),
    )
    .unwrap();
    assert_eq!(d.files, ["cradle.csv", "cradle.json.gz"]);
    // A misnamed sidecar is refused (its machine check would be skipped otherwise).
    let e = both(&files(&[
        ("cradle.csv", ROTARY.as_bytes()),
        ("side.json", SIDECAR.as_bytes()),
    ]))
    .unwrap_err();
    check(
        &e,
        "side.json",
        0,
        "",
        "the sidecar of cradle.csv is named cradle.json",
    );
    let d = both(&files(&[("runs.csv", POSITIONING.as_bytes())])).unwrap();
    assert_eq!(
        (d.kind(), d.samples(), d.declared_in),
        ("positioning", 2, None)
    );
    let e = both(&files(&[
        ("runs.csv", POSITIONING.as_bytes()),
        ("runs.json", b"{}"),
    ]))
    .unwrap_err();
    check(
        &e,
        "runs.json",
        0,
        "",
        "only a rotary point set takes a JSON sidecar",
    );
    let e = both(&files(&[("xy.csv", CSV.as_bytes())])).unwrap_err();
    check(&e, "xy.csv", 0, "", "needs its session.json");
    let e = both(&files(&[
        ("a.csv", POSITIONING.as_bytes()),
        ("b.csv", POSITIONING.as_bytes()),
    ]))
    .unwrap_err();
    check(&e, "upload", 0, "", "got 2 non-JSON files");
}

#[test]
fn a_single_file_path_reads_its_sidecar() {
    let dir = tempfile::tempdir().unwrap();
    write_dir(
        dir.path(),
        &files(&[
            ("cradle.csv", ROTARY.as_bytes()),
            ("cradle.json", SIDECAR.as_bytes()),
        ]),
    );
    let d = read_path(&dir.path().join("cradle.csv"), &Limits::default()).unwrap();
    assert_eq!(d.files, ["cradle.csv", "cradle.json"]);
}

#[test]
fn missing_paths_are_named() {
    let e = read_path(Path::new("/no/such/dir"), &Limits::default()).unwrap_err();
    check(
        &e,
        "/no/such/dir",
        0,
        "",
        "cannot read: No such file or directory (os error 2)",
    );
    let e =
        mtcal_formats::read_session_dir(Path::new("/no/such/dir"), &Limits::default()).unwrap_err();
    check(
        &e,
        "/no/such/dir",
        0,
        "",
        "cannot read the folder: No such file or directory (os error 2)",
    );
}

#[test]
fn byte_and_file_count_limits_are_limit_errors() {
    let f = session_files();
    let total: usize = f.iter().map(|(_, b)| b.len()).sum();
    let tight = Limits {
        max_bytes: total - 1,
        ..Limits::default()
    };
    let e = read_upload(&f, &tight).unwrap_err();
    assert!(e.is_limit(), "{e}");
    check(&e, "xz.csv", 0, "", "exceeds the byte limit");
    assert!(
        read_upload(
            &f,
            &Limits {
                max_bytes: total,
                ..tight
            }
        )
        .is_ok()
    );
    let e = read_upload(
        &f,
        &Limits {
            max_files: 2,
            ..Limits::default()
        },
    )
    .unwrap_err();
    assert!(e.is_limit());
    check(&e, "upload", 0, "", "exceed the limit of 2 files");
    // A rule error is not a limit error.
    let mut bad = session_files();
    bad[1].1 = b"run,t_s\n".to_vec();
    assert!(
        !read_upload(&bad, &Limits::default())
            .unwrap_err()
            .is_limit()
    );
}

/// A tar archive built entry by entry (raw headers, so that hostile entries can be made).
fn tar_of(entries: &[(&str, tar::EntryType, &[u8])]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for (path, kind, data) in entries {
        let mut h = tar::Header::new_gnu();
        // set_path refuses `..`; write the name bytes directly, as an attacker would.
        let name = &mut h.as_old_mut().name;
        name[..path.len()].copy_from_slice(path.as_bytes());
        h.set_entry_type(*kind);
        h.set_size(data.len() as u64);
        h.set_mode(0o644);
        if *kind == tar::EntryType::Symlink {
            h.set_link_name("session.json").unwrap();
        }
        h.set_cksum();
        b.append(&h, *data).unwrap();
    }
    b.into_inner().unwrap()
}

#[test]
fn archives_flatten_one_folder_and_read_like_the_folder() {
    use tar::EntryType::{Directory, Regular};
    let t = tar_of(&[
        ("s/", Directory, b""),
        ("s/session.json", Regular, JSON.as_bytes()),
        ("s/xy.csv", Regular, CSV.as_bytes()),
        ("s/._xy.csv", Regular, b"mac"),
        ("s/xz.csv", Regular, CSV.as_bytes()),
        ("s/truth.json", Regular, b"{}"),
    ]);
    for (name, bytes) in [("s.tar", t.clone()), ("s.tar.gz", gzip(&t))] {
        let files = read_archive(name, &bytes, &Limits::default()).unwrap();
        let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["session.json", "xy.csv", "xz.csv", "truth.json"]);
        let d = read_upload(&files, &Limits::default()).unwrap();
        assert_eq!((d.kind(), d.samples()), ("session", 6));
        // The same archive as a path (the CLI).
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(name), &bytes).unwrap();
        let p = read_path(&dir.path().join(name), &Limits::default()).unwrap();
        assert_eq!((p.files, p.ignored), (d.files, d.ignored));
    }
    // A .tar.gz name with plain tar content is refused, as for any .gz name.
    let e = read_archive("s.tar.gz", &t, &Limits::default()).unwrap_err();
    check(&e, "s.tar.gz", 0, "", "content is not gzip");
}

#[test]
fn hostile_archive_entries_are_refused_with_the_entry_named() {
    use tar::EntryType::{Block, Char, Fifo, Link, Regular, Symlink};
    let cases: [(&str, tar::EntryType, &str); 7] = [
        ("../session.json", Regular, "`..` are not allowed"),
        ("s/../../etc/xy.csv", Regular, "`..` are not allowed"),
        ("/etc/session.json", Regular, "absolute paths"),
        ("s/link.csv", Symlink, "a symbolic link"),
        ("s/hard.csv", Link, "a hard link"),
        ("s/dev", Char, "a device"),
        ("s/fifo", Fifo, "a FIFO"),
    ];
    for (path, kind, rule) in cases {
        let t = tar_of(&[
            ("s/session.json", Regular, JSON.as_bytes()),
            (path, kind, b""),
        ]);
        let e = read_archive("up.tar", &t, &Limits::default()).unwrap_err();
        check(&e, "up.tar", 0, "", rule);
        assert!(e.rule.contains(&format!("`{path}`")), "{e}");
    }
    let t = tar_of(&[("s/dev", Block, b"")]);
    check(
        &read_archive("up.tar", &t, &Limits::default()).unwrap_err(),
        "up.tar",
        0,
        "",
        "a device",
    );
    // The same file name in two folders.
    let t = tar_of(&[("a/xy.csv", Regular, b"1"), ("b/xy.csv", Regular, b"2")]);
    check(
        &read_archive("up.tar", &t, &Limits::default()).unwrap_err(),
        "up.tar",
        0,
        "",
        "already in the archive",
    );
    // Too many entries.
    let many: Vec<(String, tar::EntryType, &[u8])> = (0..5)
        .map(|i| (format!("f{i}.txt"), Regular, b"x".as_slice()))
        .collect();
    let many: Vec<(&str, tar::EntryType, &[u8])> =
        many.iter().map(|(n, k, d)| (n.as_str(), *k, *d)).collect();
    let e = read_archive(
        "up.tar",
        &tar_of(&many),
        &Limits {
            max_files: 4,
            ..Limits::default()
        },
    )
    .unwrap_err();
    assert!(e.is_limit());
    check(&e, "up.tar", 0, "", "more than 4 files");
    let e = read_archive("up.tar", b"not a tar", &Limits::default()).unwrap_err();
    assert_eq!(e.file, "up.tar");
}

/// An archive made as a person makes one, with `tar czf s.tar.gz -C dir .` (entries
/// `./session.json`, …), sent as the one file of an upload (a multipart part, the
/// dashboard's form) or under a name that says nothing (read by its content), reads as
/// the folder does; so does its path for the CLI's session commands.
#[test]
fn an_archive_made_with_tar_reads_as_the_one_file_of_an_upload() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("session");
    std::fs::create_dir(&src).unwrap();
    write_dir(&src, &session_files());
    let archive = dir.path().join("s.tar.gz");
    let status = std::process::Command::new("tar")
        .arg("czf")
        .arg(&archive)
        .arg("-C")
        .arg(&src)
        .arg(".")
        .status()
        .expect("tar runs");
    assert!(status.success());
    let bytes = std::fs::read(&archive).unwrap();
    let want = read_path(&src, &Limits::default()).unwrap();
    for name in ["s.tar.gz", "upload.bin", "s.tgz"] {
        let files = mtcal_formats::unpack_single_archive(
            vec![(name.into(), bytes.clone())],
            &Limits::default(),
        )
        .unwrap();
        let d = read_upload(&files, &Limits::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            (d.kind(), d.samples()),
            (want.kind(), want.samples()),
            "{name}"
        );
        assert_eq!(d.files, want.files, "{name}");
    }
    // Several files, or one file that is no archive, are left as they are.
    let plain = session_files();
    assert_eq!(
        mtcal_formats::unpack_single_archive(plain.clone(), &Limits::default()).unwrap(),
        plain
    );
    let one = files(&[("runs.csv", POSITIONING.as_bytes())]);
    assert_eq!(
        mtcal_formats::unpack_single_archive(one.clone(), &Limits::default()).unwrap(),
        one
    );
    // The CLI reads the archive where it reads a folder.
    let s = mtcal_formats::read_session_dir(&archive, &Limits::default()).unwrap();
    let folder = mtcal_formats::read_session_dir(&src, &Limits::default()).unwrap();
    assert_eq!(s.planes.len(), folder.planes.len());
    assert_eq!(s.machine_id, folder.machine_id);
}
