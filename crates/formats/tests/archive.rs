//! Archives as a person makes them (`tar`, `zip`, with or without a top folder) read as
//! the folder they were made from, whatever the archive is called; hostile zips (paths
//! out of the archive, links, bombs, too many entries, encryption, other compression
//! methods) are refused with the archive and the entry named.

use crate::common::check;
use crate::upload::{CSV, JSON, POSITIONING};
use mtcal_formats::{Limits, read_archive, read_path, read_upload, unpack_single_archive};
use std::io::Write;
use std::path::Path;
use std::process::Command;

/// A folder `root/session` holding a session of 6 samples.
fn session_folder(root: &Path) -> std::path::PathBuf {
    let dir = root.join("session");
    std::fs::create_dir(&dir).unwrap();
    for (n, b) in [("session.json", JSON), ("xy.csv", CSV), ("xz.csv", CSV)] {
        std::fs::write(dir.join(n), b).unwrap();
    }
    dir
}

/// Runs a command in `cwd`; it must succeed.
fn run(cwd: &Path, program: &str, args: &[&str]) {
    let out = Command::new(program)
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("{program} runs: {e}"));
    assert!(out.status.success(), "{program} {args:?}: {out:?}");
}

/// The archives a person makes of `root/session`, with the commands that made them: top
/// folder or none, tar or zip.
fn archives_of_session(root: &Path) -> Vec<(&'static str, std::path::PathBuf)> {
    let made = [
        (
            "tar czf a.tgz -C session .",
            "a.tgz",
            "tar",
            &["czf", "a.tgz", "-C", "session", "."][..],
        ),
        (
            "tar czf b.tar.gz session",
            "b.tar.gz",
            "tar",
            &["czf", "b.tar.gz", "session"][..],
        ),
        (
            "tar cf c.tar session",
            "c.tar",
            "tar",
            &["cf", "c.tar", "session"][..],
        ),
        (
            "zip -r d.zip session",
            "d.zip",
            "zip",
            &["-qr", "d.zip", "session"][..],
        ),
    ];
    let mut out = vec![];
    for (what, name, program, args) in made {
        run(root, program, args);
        out.push((what, root.join(name)));
    }
    // zip without a top folder: made inside the folder.
    run(&root.join("session"), "zip", &["-qr", "../e.zip", "."]);
    out.push(("cd session && zip -r ../e.zip .", root.join("e.zip")));
    out
}

#[test]
fn archives_made_with_tar_and_zip_read_as_their_folder() {
    let root = tempfile::tempdir().unwrap();
    let folder = session_folder(root.path());
    let want = read_path(&folder, &Limits::default()).unwrap();
    assert_eq!((want.kind(), want.samples()), ("session", 6));
    for (what, path) in archives_of_session(root.path()) {
        let bytes = std::fs::read(&path).unwrap();
        let name = path.file_name().unwrap().to_str().unwrap();
        // As the one file of an upload, under its own name or one that says nothing
        // (a raw body, a browser's generic name): read by its content.
        for as_named in [name, "upload.bin"] {
            let files =
                unpack_single_archive(vec![(as_named.into(), bytes.clone())], &Limits::default())
                    .unwrap_or_else(|e| panic!("{what} as {as_named}: {e}"));
            let d = read_upload(&files, &Limits::default())
                .unwrap_or_else(|e| panic!("{what} as {as_named}: {e}"));
            assert_eq!((d.kind(), d.samples()), ("session", 6), "{what}");
            assert_eq!(d.files, want.files, "{what}");
        }
        // As a path (the CLI reads an archive where it reads a folder).
        let d = read_path(&path, &Limits::default()).unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(d.files, want.files, "{what}");
        let s = mtcal_formats::read_session_dir(&path, &Limits::default())
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(
            (s.machine_id.as_str(), s.planes.len()),
            ("VMC-0042", 2),
            "{what}"
        );
    }
}

#[test]
fn a_zipped_series_file_reads_as_the_file() {
    let root = tempfile::tempdir().unwrap();
    std::fs::write(root.path().join("runs.csv"), POSITIONING).unwrap();
    run(root.path(), "zip", &["-q", "runs.zip", "runs.csv"]);
    let d = read_path(&root.path().join("runs.zip"), &Limits::default()).unwrap();
    assert_eq!((d.kind(), d.samples()), ("positioning", 2));
    assert_eq!(d.files, ["runs.csv"]);
}

/// A zip written entry by entry (so that hostile entries can be made).
enum Entry<'a> {
    File(&'a str, &'a [u8]),
    Folder(&'a str),
    Link(&'a str),
}

fn zip_of(entries: &[Entry]) -> Vec<u8> {
    use zip::write::SimpleFileOptions;
    let deflated =
        SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let mut w = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    for e in entries {
        match e {
            Entry::File(name, data) => {
                w.start_file(*name, deflated).unwrap();
                w.write_all(data).unwrap();
            }
            Entry::Folder(name) => w.add_directory(*name, deflated).unwrap(),
            Entry::Link(name) => w.add_symlink(*name, "/etc/passwd", deflated).unwrap(),
        }
    }
    w.finish().unwrap().into_inner()
}

#[test]
fn hostile_zip_entries_are_refused_with_the_entry_named() {
    use Entry::{File, Link};
    let cases: [(Entry, &str, &str); 4] = [
        (
            File("../session.json", b"{}"),
            "../session.json",
            "`..` are not allowed",
        ),
        (
            File("s/../../xy.csv", b"1"),
            "s/../../xy.csv",
            "`..` are not allowed",
        ),
        (File("/etc/xy.csv", b"1"), "/etc/xy.csv", "absolute paths"),
        (Link("s/link.csv"), "s/link.csv", "a symbolic link"),
    ];
    for (entry, path, rule) in cases {
        let z = zip_of(&[File("s/session.json", JSON.as_bytes()), entry]);
        let e = read_archive("up.zip", &z, &Limits::default()).unwrap_err();
        check(&e, "up.zip", 0, "", rule);
        assert!(e.rule.contains(&format!("`{path}`")), "{e}");
        assert!(!e.is_limit(), "{e}");
    }
    let z = zip_of(&[File("a/xy.csv", b"1"), File("b/xy.csv", b"2")]);
    let e = read_archive("up.zip", &z, &Limits::default()).unwrap_err();
    check(
        &e,
        "up.zip",
        0,
        "",
        "a file named `xy.csv` is already in the archive",
    );
    // Not a zip after all: a truncated one.
    let z = zip_of(&[File("xy.csv", CSV.as_bytes())]);
    let e = read_archive("up.zip", &z[..z.len() - 30], &Limits::default()).unwrap_err();
    check(&e, "up.zip", 0, "", "not a readable zip archive");
}

#[test]
fn zip_bombs_and_entry_counts_are_limit_errors() {
    use Entry::{File, Folder};
    // 8 MiB of zeros deflate to a few KiB: refused while decompressing, at the limit.
    let zeros = vec![0u8; 8 << 20];
    let z = zip_of(&[File("xy.csv", &zeros)]);
    assert!(z.len() < 64 << 10, "the bomb is small: {}", z.len());
    let limits = Limits {
        max_bytes: 1 << 20,
        ..Limits::default()
    };
    let e = read_archive("bomb.zip", &z, &limits).unwrap_err();
    assert!(e.is_limit(), "{e}");
    check(
        &e,
        "bomb.zip",
        0,
        "",
        "unpacks to more than the byte limit of 1048576 bytes",
    );
    // Two entries each within the limit, together over it.
    let half = vec![0u8; 600 << 10];
    let z = zip_of(&[File("a.csv", &half), File("b.csv", &half)]);
    assert!(read_archive("two.zip", &z, &limits).unwrap_err().is_limit());
    assert_eq!(
        read_archive("two.zip", &z, &Limits::default())
            .unwrap()
            .len(),
        2
    );
    // Too many files; too many folders.
    let names: Vec<String> = (0..5).map(|i| format!("f{i}.csv")).collect();
    let many: Vec<Entry> = names.iter().map(|n| File(n, b"x")).collect();
    let four = Limits {
        max_files: 4,
        ..Limits::default()
    };
    let e = read_archive("many.zip", &zip_of(&many), &four).unwrap_err();
    assert!(e.is_limit());
    check(&e, "many.zip", 0, "", "more than 4 files in the archive");
    let dirs: Vec<String> = (0..=mtcal_formats::archive::MAX_FOLDERS)
        .map(|i| format!("d{i}/"))
        .collect();
    let many: Vec<Entry> = dirs.iter().map(|n| Folder(n)).collect();
    let e = read_archive("dirs.zip", &zip_of(&many), &Limits::default()).unwrap_err();
    assert!(e.is_limit());
    check(&e, "dirs.zip", 0, "", "folders in the archive");
    // Folders and macOS metadata only: no files.
    let z = zip_of(&[Folder("s/"), File("__MACOSX/s/._xy.csv", b"mac")]);
    check(
        &read_archive("empty.zip", &z, &Limits::default()).unwrap_err(),
        "empty.zip",
        0,
        "",
        "no files in the archive",
    );
}

#[test]
fn encrypted_zips_and_other_compression_methods_are_refused_with_what_to_do() {
    let root = tempfile::tempdir().unwrap();
    let folder = session_folder(root.path());
    // A CSV large enough for bzip2 to be used rather than stored.
    let big: String = (0..2000)
        .map(|i| format!("1,{i}.0,0,0,0,0.1,0.2\n"))
        .collect();
    std::fs::write(
        folder.join("xy.csv"),
        format!("run,t_s,x_mm,y_mm,z_mm,du_um,dv_um\n{big}"),
    )
    .unwrap();
    run(
        root.path(),
        "zip",
        &["-q", "-P", "secret", "locked.zip", "session/xy.csv"],
    );
    run(
        root.path(),
        "zip",
        &["-q", "-Z", "bzip2", "bz.zip", "session/xy.csv"],
    );
    let read = |name: &str| {
        let bytes = std::fs::read(root.path().join(name)).unwrap();
        read_archive(name, &bytes, &Limits::default()).unwrap_err()
    };
    check(
        &read("locked.zip"),
        "locked.zip",
        0,
        "",
        "entry `session/xy.csv` is encrypted",
    );
    let e = read("bz.zip");
    check(
        &e,
        "bz.zip",
        0,
        "",
        "entry `session/xy.csv` is compressed with",
    );
    assert!(e.rule.contains("deflate"), "{e}");
}
