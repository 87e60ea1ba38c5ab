//! Measurement sessions (datasets contract, section 1; `docs/datasets.md`): a folder with
//! `session.json` and one CSV per plate mounting and plane.
//!
//! `session.json` rules: `machine_id` (non-empty string) and `measured_at` (RFC 3339)
//! required; `topology` optional (`{"workpiece": [..], "tool": [..]}` listing X, Y and Z
//! exactly once); `temperature_c` optional finite number; `notes` optional string; the
//! test's conditions optional (`operator`, `instrument` with its calibration,
//! `temperature_u_k`, `machine_expansion_ppm_per_k`, `machine_expansion_u_ppm_per_k`,
//! `alignment_urad`: [`mtcal_solver::uncertainty::Conditions`], numbers checked there);
//! `planes` a non-empty array of `{file, plane, head_offset_mm, mounting?}` with `plane`
//! one of XY, XZ, YZ, `head_offset_mm` three finite numbers, `file` a plain file name
//! (no directory part) named once; `mounting` defaults to the file's own name (one
//! mounting per file) and files sharing a mounting must share the plane; unknown fields
//! rejected unless `x-` prefixed.
//!
//! Plane CSV rules (on top of `csv_core`): columns `run, t_s, x_mm, y_mm, z_mm, du_um,
//! dv_um` required, `temp_c` and `test` optional; `run` an integer; `t_s` strictly
//! increasing within a run; `test` one of line_X, line_Y, line_Z, circle_cw, circle_ccw,
//! free (an empty cell means "infer"), constant within a run; at least one sample.

use crate::csv_core::{CsvTable, check_increasing};
use crate::csv_out::CsvOut;
use crate::json::{JsonDoc, Obj};
use crate::limits::Quantity;
use crate::{FormatError, Limits, gzip, invalid_input};
use mtcal_solver::session::{PlaneRecord, Run, Session, TestKind};
use mtcal_solver::uncertainty::{Conditions, Instrument};
use mtcal_solver::{Axis, Plane, Topology};
use serde_json::{Value, json};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::io::Write;
use std::path::Path;

/// Name of the session description inside a session folder.
pub const SESSION_JSON: &str = "session.json";

/// Columns of a plane CSV, required first.
pub const PLANE_COLUMNS: [&str; 9] = [
    "run", "t_s", "x_mm", "y_mm", "z_mm", "du_um", "dv_um", "temp_c", "test",
];
const REQUIRED: usize = 7;

const TEST_NAMES: &str = "line_X, line_Y, line_Z, circle_cw, circle_ccw, free";

/// session.json without the runs.
struct PlaneSpec {
    file: String,
    plane: Plane,
    head_offset_mm: [f64; 3],
    mounting: String,
}

struct SessionSpec {
    machine_id: String,
    measured_at: String,
    topology: Option<Topology>,
    notes: Option<String>,
    conditions: Conditions,
    planes: Vec<PlaneSpec>,
}

/// Reads a session folder: `dir/session.json` (or `session.json.gz`) and the plane files
/// it names, with the rules of an upload (`docs/datasets.md`, "Uploads"): a plane file
/// named `f` may be present as `f.gz`; a CSV the description does not name is refused;
/// other files (`truth.json`, notes) are ignored. Error messages name files relative to
/// `dir`. `dir` may also be a `.tar`, `.tar.gz` or `.tgz` archive of such a folder (with
/// or without its top folder), read as the same upload would be.
pub fn read_session_dir(dir: &Path, limits: &Limits) -> Result<Session, FormatError> {
    if dir.is_file() && crate::is_archive_name(&crate::display_name(dir)) {
        return match crate::read_path(dir, limits)?.data {
            crate::DatasetData::Session(s) => Ok(s),
            other => Err(FormatError::file(
                crate::display_name(dir),
                format!(
                    "the archive holds a {} dataset, not a session (session.json and its \
                     plane CSVs)",
                    other.kind()
                ),
            )),
        };
    }
    let (names, mut load) = crate::files::folder(dir, limits)?;
    if !names
        .iter()
        .any(|n| n == SESSION_JSON || n == SESSION_JSON_GZ)
    {
        return Err(FormatError::file(
            SESSION_JSON,
            format!("missing from the folder {}", dir.display()),
        ));
    }
    read_session_named(&names, &mut load, limits).map(|r| r.session)
}

/// Reads a session from memory (an HTTP upload): `session_json` and the other files keyed
/// by name, with the rules of an upload (`docs/datasets.md`, "Uploads"; an entry named
/// `session.json` in `files` is ignored: `session_json` is the description).
pub fn read_session_files(
    session_json: &[u8],
    files: &BTreeMap<String, Vec<u8>>,
    limits: &Limits,
) -> Result<Session, FormatError> {
    let names: Vec<String> = std::iter::once(SESSION_JSON.to_string())
        .chain(files.keys().filter(|k| k.as_str() != SESSION_JSON).cloned())
        .collect();
    let mut load = |name: &str, _: Vec<u8>| -> Result<Cow<'_, [u8]>, FormatError> {
        Ok(Cow::Borrowed(if name == SESSION_JSON {
            session_json
        } else {
            &files[name]
        }))
    };
    read_session_named(&names, &mut load, limits).map(|r| r.session)
}

/// Name of a gzip-compressed session description.
pub const SESSION_JSON_GZ: &str = "session.json.gz";

/// A session read from the files of an upload.
pub(crate) struct SessionRead {
    pub session: Session,
    /// The description's name (`session.json` or `session.json.gz`).
    pub description: String,
    /// Every file read, the description first.
    pub files: Vec<String>,
    /// Files present but not part of the session (not CSV, not named by the description),
    /// sorted.
    pub ignored: Vec<String>,
}

/// Whether a file name is a CSV's (`.csv`, `.csv.gz`, any case).
pub(crate) fn is_csv_name(name: &str) -> bool {
    let n = name.to_ascii_lowercase();
    n.ends_with(".csv") || n.ends_with(".csv.gz")
}

/// The one session reader, over the names of an upload's files and a loader of their
/// bytes as stored (`load` is called once per file read). The description is
/// `session.json` or `session.json.gz` (not both); a plane file named `f` is `f` or
/// `f.gz` in the upload (not both); a CSV the description does not name is an error;
/// other unnamed files are ignored (listed in [`SessionRead::ignored`]). The byte limit
/// applies to the sum of the stored sizes of the files read and, separately, to the sum
/// of their decompressed sizes.
pub(crate) fn read_session_named<'a>(
    names: &[String],
    load: &mut crate::files::Loader<'a>,
    limits: &Limits,
) -> Result<SessionRead, FormatError> {
    let has = |n: &str| names.iter().any(|m| m == n);
    let description = match (has(SESSION_JSON), has(SESSION_JSON_GZ)) {
        (true, true) => {
            return Err(FormatError::file(
                SESSION_JSON_GZ,
                "given twice: session.json and session.json.gz",
            ));
        }
        (true, false) => SESSION_JSON,
        (false, true) => SESSION_JSON_GZ,
        (false, false) => {
            return Err(FormatError::file(
                SESSION_JSON,
                "missing: a session needs its description session.json",
            ));
        }
    };
    let mut raw_budget = limits.max_bytes;
    let mut budget = limits.max_bytes;
    let mut read = |name: &str,
                    raw_budget: &mut usize,
                    spare: Vec<u8>|
     -> Result<Cow<'a, [u8]>, FormatError> {
        let raw = load(name, spare)?;
        *raw_budget = raw_budget.checked_sub(raw.len()).ok_or_else(|| {
            FormatError::file(
                name,
                format!(
                    "upload exceeds the byte limit of {} bytes (stored sizes of the files read)",
                    limits.max_bytes
                ),
            )
            .as_limit()
        })?;
        Ok(raw)
    };
    let raw = read(description, &mut raw_budget, Vec::new())?;
    let json = gzip::decode(description, &raw, &mut budget)?;
    let (spec, doc) = parse_session_json(&json, limits)?;
    drop(json);
    drop(raw);
    let mut stored: Vec<String> = Vec::with_capacity(spec.planes.len());
    for (i, p) in spec.planes.iter().enumerate() {
        let gz = format!("{}.gz", p.file);
        let name = match (has(&p.file), has(&gz)) {
            (true, true) => {
                return Err(FormatError::file(
                    gz.as_str(),
                    format!("given twice: `{}` and `{gz}`", p.file),
                ));
            }
            (true, false) => p.file.clone(),
            (false, true) => gz,
            (false, false) => {
                return Err(doc.error(
                    &format!("planes[{i}].file"),
                    format!(
                        "referenced file `{}` is missing (looked for `{}` and `{gz}`)",
                        p.file, p.file
                    ),
                ));
            }
        };
        stored.push(name);
    }
    let mut ignored = Vec::new();
    for n in names {
        if n == SESSION_JSON || n == SESSION_JSON_GZ || stored.contains(n) {
            continue;
        }
        if is_csv_name(n) {
            return Err(FormatError::file(
                n.as_str(),
                "uploaded file is not referenced by session.json (a CSV beside a session \
                 must be one of its planes)",
            ));
        }
        ignored.push(n.clone());
    }
    ignored.sort();
    // Each plane file is loaded and decompressed in file order (the byte budgets are
    // shared and charged in that order) and parsed on all cores as soon as it is loaded.
    let mut load_plane = |i: usize, spare: Vec<u8>| -> Result<Cow<'a, [u8]>, FormatError> {
        let raw = read(&stored[i], &mut raw_budget, spare)?;
        let decompressed = match gzip::decode(&stored[i], &raw, &mut budget)? {
            Cow::Owned(plain) => Some(plain),
            Cow::Borrowed(_) => None,
        };
        Ok(decompressed.map_or(raw, Cow::Owned))
    };
    let mut parsed = parse_planes(&stored, &mut load_plane, limits)?.into_iter();
    let session = assemble(spec, |_, _| {
        Ok(parsed
            .next()
            .expect("one parsed plane file per plane of the description"))
    })?;
    let files = std::iter::once(description.to_string())
        .chain(stored)
        .collect();
    Ok(SessionRead {
        session,
        description: description.to_string(),
        files,
        ignored,
    })
}

/// Reads the plane files `names` with [`read_plane_csv`] on up to
/// [`std::thread::available_parallelism`] threads: the files are loaded one after the
/// other by `load` (here, in file order) and each is parsed by the next free worker, so at
/// most one file per worker and one being handed over are in memory besides the columns
/// read. The result is a sequential read's: the runs of every file in order, or the first
/// error in file order (a file that cannot be loaded counts after the files before it;
/// files after an error are not loaded). The buffers of parsed files go back to `load`
/// as its spare buffer (see [`crate::files::Loader`]).
fn parse_planes<'a>(
    names: &[String],
    load: &mut dyn FnMut(usize, Vec<u8>) -> Result<Cow<'a, [u8]>, FormatError>,
    limits: &Limits,
) -> Result<Vec<Vec<Run>>, FormatError> {
    use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
    use std::sync::{Arc, Mutex, PoisonError, mpsc};
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(names.len());
    let spare_of = |data: Cow<'a, [u8]>| match data {
        Cow::Owned(buf) => buf,
        Cow::Borrowed(_) => Vec::new(),
    };
    if threads <= 1 {
        let mut spare = Vec::new();
        return (0..names.len())
            .map(|i| {
                let data = load(i, std::mem::take(&mut spare))?;
                let runs = read_plane_csv(&names[i], &data, limits);
                spare = spare_of(data);
                runs
            })
            .collect();
    }
    // The lowest index of a file that failed: later files need not be read.
    let failed = AtomicUsize::new(usize::MAX);
    let mut results: Vec<Option<Result<Vec<Run>, FormatError>>> = Vec::new();
    results.resize_with(names.len(), || None);
    std::thread::scope(|s| {
        // A rendezvous channel: a loaded file waits until a worker takes it. The workers
        // share the receiver; when they are all gone, a send fails instead of blocking.
        let (tx, rx) = mpsc::sync_channel::<(usize, Cow<'a, [u8]>)>(0);
        let rx = Arc::new(Mutex::new(rx));
        let (spare_tx, spare_rx) = mpsc::channel::<Vec<u8>>();
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                let rx = Arc::clone(&rx);
                let spare_tx = spare_tx.clone();
                let failed = &failed;
                s.spawn(move || {
                    let mut mine = Vec::new();
                    loop {
                        let next = rx.lock().unwrap_or_else(PoisonError::into_inner).recv();
                        let Ok((i, data)) = next else {
                            break mine;
                        };
                        if i > failed.load(Relaxed) {
                            continue;
                        }
                        let r = read_plane_csv(&names[i], &data, limits);
                        // The loader may be gone (after an error): then it is dropped.
                        let _ = spare_tx.send(spare_of(data));
                        if r.is_err() {
                            failed.fetch_min(i, Relaxed);
                        }
                        mine.push((i, r));
                    }
                })
            })
            .collect();
        drop((rx, spare_tx));
        for i in 0..names.len() {
            if failed.load(Relaxed) < i {
                break;
            }
            match load(i, spare_rx.try_recv().unwrap_or_default()) {
                Ok(data) => {
                    if tx.send((i, data)).is_err() {
                        break;
                    }
                }
                Err(e) => {
                    results[i] = Some(Err(e));
                    break;
                }
            }
        }
        drop(tx);
        for w in workers {
            for (i, r) in w.join().unwrap_or_else(|p| std::panic::resume_unwind(p)) {
                results[i] = Some(r);
            }
        }
    });
    results
        .into_iter()
        .map(|r| r.expect("a file is left unread only after an earlier file's error"))
        .collect()
}

fn assemble(
    spec: SessionSpec,
    mut load: impl FnMut(usize, &PlaneSpec) -> Result<Vec<Run>, FormatError>,
) -> Result<Session, FormatError> {
    let mut planes = Vec::with_capacity(spec.planes.len());
    for (i, p) in spec.planes.iter().enumerate() {
        let runs = load(i, p)?;
        planes.push(PlaneRecord {
            file: p.file.clone(),
            plane: p.plane,
            head_offset_mm: p.head_offset_mm,
            mounting: p.mounting.clone(),
            runs,
        });
    }
    Ok(Session {
        machine_id: spec.machine_id,
        measured_at: spec.measured_at,
        topology: spec.topology,
        notes: spec.notes,
        conditions: spec.conditions,
        planes,
    })
}

/// Checks a file name taken from session.json: a plain name inside the folder.
fn valid_file_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && name != SESSION_JSON
        && !name.contains(['/', '\\', '\0', ':'])
}

fn parse_session_json(
    bytes: &[u8],
    limits: &Limits,
) -> Result<(SessionSpec, JsonDoc<'static>), FormatError> {
    let doc = JsonDoc::parse(SESSION_JSON, bytes)?;
    let spec = {
        let root = doc.root()?;
        root.check_fields(&[
            "machine_id",
            "measured_at",
            "topology",
            "temperature_c",
            "notes",
            "planes",
            "operator",
            "instrument",
            "temperature_u_k",
            "machine_expansion_ppm_per_k",
            "machine_expansion_u_ppm_per_k",
            "alignment_urad",
        ])?;
        let machine_id = root.req_str("machine_id")?.to_string();
        root.req_str("measured_at")?;
        let measured_at = root
            .opt_timestamp("measured_at")?
            .unwrap_or_default()
            .to_string();
        let topology = match root.get("topology") {
            None => None,
            Some(v) => Some(parse_topology(&root.object("topology", v)?)?),
        };
        let notes = root.opt_str("notes")?.map(str::to_string);
        let conditions = parse_conditions(&root, limits)?;
        let planes_v = root.required("planes")?;
        let Value::Array(items) = planes_v else {
            return Err(root.error("planes", "must be an array of plane objects"));
        };
        if items.is_empty() {
            return Err(root.error("planes", "must list at least one plane file"));
        }
        let mut planes: Vec<PlaneSpec> = Vec::with_capacity(items.len());
        let mut mountings: HashMap<String, Plane> = HashMap::new();
        // Files named so far: a set, so that a long list costs O(n), not O(n²).
        let mut files: HashSet<String> = HashSet::with_capacity(items.len());
        for (i, item) in items.iter().enumerate() {
            let p = root.object(&format!("planes[{i}]"), item)?;
            let spec = parse_plane(&p, limits)?;
            if !files.insert(spec.file.clone()) {
                return Err(p.error("file", format!("file `{}` is listed twice", spec.file)));
            }
            if let Some(&other) = mountings.get(&spec.mounting)
                && other != spec.plane
            {
                return Err(p.error(
                    "mounting",
                    format!(
                        "mounting `{}` is used in plane {other} and plane {}: files sharing a mounting must share the plane",
                        spec.mounting, spec.plane
                    ),
                ));
            }
            mountings.insert(spec.mounting.clone(), spec.plane);
            planes.push(spec);
        }
        SessionSpec {
            machine_id,
            measured_at,
            topology,
            notes,
            conditions,
            planes,
        }
    };
    Ok((spec, doc))
}

/// The test's conditions stated in session.json (docs/datasets.md, "session.json"): the
/// operator, the instrument with its calibration, the temperature and the budget's other
/// inputs, each checked with the field named.
fn parse_conditions(root: &Obj<'_>, limits: &Limits) -> Result<Conditions, FormatError> {
    // Every number within the bound of its quantity (docs/datasets.md, "Limits"), as in
    // the CSV files: a finite but absurd value would make the budget's figures overflow.
    let value = |o: &Obj<'_>, field: &str| o.opt_f64_within(field, Quantity::Value, limits);
    let kelvin = |o: &Obj<'_>, field: &str| o.opt_f64_within(field, Quantity::Temperature, limits);
    let text = |o: &Obj<'_>, field: &str| -> Result<Option<String>, FormatError> {
        match o.opt_str(field)? {
            Some(s) if s.trim().is_empty() => Err(o.error(field, "must not be empty")),
            Some(s) if s.len() > TEXT_MAX || s.chars().any(char::is_control) => Err(o.error(
                field,
                format!("at most {TEXT_MAX} bytes, no control characters"),
            )),
            other => Ok(other.map(str::to_string)),
        }
    };
    let instrument = match root.get("instrument") {
        None => None,
        Some(v) => {
            let o = root.object("instrument", v)?;
            o.check_fields(&[
                "model",
                "serial",
                "calibration_date",
                "certificate",
                "calibration_u_um",
                "calibration_u_um_per_m",
                "calibration_k",
                "squareness_u_urad",
                "expansion_ppm_per_k",
                "expansion_u_ppm_per_k",
            ])?;
            let i = Instrument {
                model: text(&o, "model")?,
                serial: text(&o, "serial")?,
                calibration_date: text(&o, "calibration_date")?,
                certificate: text(&o, "certificate")?,
                calibration_u_um: value(&o, "calibration_u_um")?,
                calibration_u_um_per_m: value(&o, "calibration_u_um_per_m")?,
                calibration_k: value(&o, "calibration_k")?,
                squareness_u_urad: value(&o, "squareness_u_urad")?,
                expansion_ppm_per_k: value(&o, "expansion_ppm_per_k")?,
                expansion_u_ppm_per_k: value(&o, "expansion_u_ppm_per_k")?,
            };
            if let Err(m) = i.validate("") {
                let field = m.split(':').next().unwrap_or("").to_string();
                return Err(o.error(&field, m[field.len() + 1..].trim().to_string()));
            }
            Some(i)
        }
    };
    let temperature_c = root.opt_f64_within("temperature_c", Quantity::Temperature, limits)?;
    let c = Conditions {
        operator: text(root, "operator")?,
        instrument,
        temperature_c,
        temperature_source: temperature_c.map(|_| "stated".to_string()),
        temperature_u_k: kelvin(root, "temperature_u_k")?,
        machine_expansion_ppm_per_k: value(root, "machine_expansion_ppm_per_k")?,
        machine_expansion_u_ppm_per_k: value(root, "machine_expansion_u_ppm_per_k")?,
        alignment_urad: value(root, "alignment_urad")?,
    };
    if let Err(m) = c.validate() {
        let field = m.split(':').next().unwrap_or("").to_string();
        return Err(root.error(&field, m[field.len() + 1..].trim().to_string()));
    }
    Ok(c)
}

/// Longest text field of session.json's conditions (operator, instrument names), bytes.
pub const TEXT_MAX: usize = 200;

fn parse_topology(o: &Obj<'_>) -> Result<Topology, FormatError> {
    o.check_fields(&["workpiece", "tool"])?;
    let stack = |field: &str| -> Result<Vec<Axis>, FormatError> {
        let Some(Value::Array(items)) = o.get(field) else {
            return Err(o.error(
                field,
                "must be an array of axis names (\"X\", \"Y\", \"Z\")",
            ));
        };
        items
            .iter()
            .map(|v| {
                v.as_str()
                    .and_then(Axis::parse)
                    .ok_or_else(|| o.error(field, format!("`{v}` is not an axis name (X, Y or Z)")))
            })
            .collect()
    };
    let topology = Topology {
        workpiece: stack("workpiece")?,
        tool: stack("tool")?,
    };
    topology.validate().map_err(|e| o.error("", e))?;
    Ok(topology)
}

fn parse_plane(p: &Obj<'_>, limits: &Limits) -> Result<PlaneSpec, FormatError> {
    p.check_fields(&["file", "plane", "head_offset_mm", "mounting"])?;
    let file = p.req_str("file")?.to_string();
    if !valid_file_name(&file) {
        return Err(p.error(
            "file",
            format!("`{file}` is not a plain file name inside the session folder"),
        ));
    }
    let plane_s = p.req_str("plane")?;
    let plane = Plane::parse(plane_s).ok_or_else(|| {
        p.error(
            "plane",
            format!("`{plane_s}` is not a plane (XY, XZ or YZ)"),
        )
    })?;
    let offset = p.required("head_offset_mm")?;
    let head_offset_mm = match offset {
        Value::Array(a) if a.len() == 3 => {
            let mut t = [0.0; 3];
            for (k, v) in a.iter().enumerate() {
                t[k] = v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
                    p.error("head_offset_mm", "must hold three finite numbers (mm)")
                })?;
                if let Some(why) = Quantity::Position.beyond(t[k], limits) {
                    return Err(p.error("head_offset_mm", why));
                }
            }
            t
        }
        _ => {
            return Err(p.error(
                "head_offset_mm",
                "must be an array of three finite numbers (mm)",
            ));
        }
    };
    let mounting = match p.opt_str("mounting")? {
        None => file.clone(),
        Some(m) if m.trim().is_empty() => return Err(p.error("mounting", "must not be empty")),
        Some(m) => m.to_string(),
    };
    Ok(PlaneSpec {
        file,
        plane,
        head_offset_mm,
        mounting,
    })
}

/// Reads one plane CSV (already decompressed) into runs, in order of first appearance.
pub fn read_plane_csv(file: &str, bytes: &[u8], limits: &Limits) -> Result<Vec<Run>, FormatError> {
    let mut t = CsvTable::open(file, bytes, limits)?;
    let c = t.check_schema(&PLANE_COLUMNS, REQUIRED)?;
    let (c_run, c_t, c_x, c_y, c_z, c_du, c_dv) = (c[0], c[1], c[2], c[3], c[4], c[5], c[6]);
    let c_temp = t.col("temp_c");
    let c_test = t.col("test");
    let mut numbers = vec![(c_t, Quantity::Time)];
    numbers.extend([c_x, c_y, c_z].map(|c| (c, Quantity::Position)));
    numbers.extend([c_du, c_dv].map(|c| (c, Quantity::Deviation)));
    numbers.extend(c_temp.map(|c| (c, Quantity::Temperature)));
    t.scan(&numbers);

    let mut runs: Vec<Run> = Vec::new();
    let mut by_number: HashMap<i64, usize> = HashMap::new();
    let mut cur: Option<usize> = None;
    while t.next_row()? {
        let number = t.int(c_run)?;
        let k = match cur {
            Some(k) if runs[k].number == number => k,
            _ => {
                if let Some(prev) = cur {
                    shrink(&mut runs[prev]);
                }
                let k = *by_number.entry(number).or_insert_with(|| {
                    let hint = t.remaining_rows_hint();
                    runs.push(new_run(number, hint, c_temp.is_some()));
                    runs.len() - 1
                });
                cur = Some(k);
                k
            }
        };
        let ts = t.quantity(c_t, Quantity::Time)?;
        let run = &mut runs[k];
        check_increasing(
            &t,
            c_t,
            run.t_s.last().copied(),
            ts,
            format_args!("run {number}"),
        )?;
        let position = |c| t.quantity(c, Quantity::Position);
        let pos = [position(c_x)?, position(c_y)?, position(c_z)?];
        let deviation = |c| t.quantity(c, Quantity::Deviation);
        let du = deviation(c_du)?;
        let dv = deviation(c_dv)?;
        let temp = c_temp
            .map(|c| t.quantity(c, Quantity::Temperature))
            .transpose()?;
        if let Some(c) = c_test {
            let s = t.text(c);
            // Most rows repeat their run's label: compared with it, not parsed again.
            let same = !run.t_s.is_empty() && s == run.test.map_or("", TestKind::name);
            if !same {
                let label = if s.is_empty() {
                    None
                } else {
                    Some(TestKind::parse(s).ok_or_else(|| {
                        t.cell_error(
                            c,
                            format!(
                                "`{s}` is not a test kind (expected one of {TEST_NAMES}, or empty)"
                            ),
                        )
                    })?)
                };
                if run.t_s.is_empty() {
                    run.test = label;
                } else if run.test != label {
                    let name = |l: Option<TestKind>| l.map_or("(empty)", TestKind::name);
                    return Err(t.cell_error(
                        c,
                        format!(
                            "test label changes within run {number}: `{}` after `{}`",
                            name(label),
                            name(run.test)
                        ),
                    ));
                }
            }
        }
        run.t_s.push(ts);
        run.pos_mm.push(pos);
        run.du_um.push(du);
        run.dv_um.push(dv);
        if let (Some(v), Some(temps)) = (temp, run.temp_c.as_mut()) {
            temps.push(v);
        }
    }
    if t.rows() == 0 {
        return Err(t.header_error("", "the file has no samples after the header"));
    }
    if let Some(k) = cur {
        shrink(&mut runs[k]);
    }
    crate::units::check_micrometres(file, "du_um", runs.iter().map(|r| r.du_um.as_slice()))?;
    crate::units::check_micrometres(file, "dv_um", runs.iter().map(|r| r.dv_um.as_slice()))?;
    crate::units::check_speed(
        file,
        runs.iter().map(|r| (r.t_s.as_slice(), r.pos_mm.as_slice())),
    )?;
    Ok(runs)
}

fn new_run(number: i64, hint: usize, temp: bool) -> Run {
    Run {
        number,
        test: None,
        t_s: Vec::with_capacity(hint),
        pos_mm: Vec::with_capacity(hint),
        du_um: Vec::with_capacity(hint),
        dv_um: Vec::with_capacity(hint),
        temp_c: temp.then(|| Vec::with_capacity(hint)),
    }
}

/// Gives back the capacity reserved for rows that belonged to other runs.
fn shrink(run: &mut Run) {
    run.t_s.shrink_to_fit();
    run.pos_mm.shrink_to_fit();
    run.du_um.shrink_to_fit();
    run.dv_um.shrink_to_fit();
    if let Some(t) = run.temp_c.as_mut() {
        t.shrink_to_fit();
    }
}

/// Checks runs before writing: equal column lengths, finite values, temperatures for all
/// runs or none, and (like the reader) strictly increasing time within each run.
fn check_runs(runs: &[Run]) -> std::io::Result<()> {
    let temp = runs.first().is_some_and(|r| r.temp_c.is_some());
    for r in runs {
        let n = r.t_s.len();
        if r.pos_mm.len() != n
            || r.du_um.len() != n
            || r.dv_um.len() != n
            || r.temp_c.as_ref().is_some_and(|t| t.len() != n)
        {
            return Err(invalid_input(format!(
                "run {}: columns of unequal length",
                r.number
            )));
        }
        if r.temp_c.is_some() != temp {
            return Err(invalid_input(
                "temp_c must be given for all runs of a file or none",
            ));
        }
        let mut values = r
            .t_s
            .iter()
            .chain(r.pos_mm.iter().flatten())
            .chain(&r.du_um)
            .chain(&r.dv_um)
            .chain(r.temp_c.iter().flatten());
        if values.any(|v| !v.is_finite()) {
            return Err(invalid_input(format!("run {}: non-finite value", r.number)));
        }
        if r.t_s.windows(2).any(|w| w[1] <= w[0]) {
            return Err(invalid_input(format!(
                "run {}: t_s is not strictly increasing",
                r.number
            )));
        }
    }
    Ok(())
}

/// Writes a plane CSV: `run,t_s,x_mm,y_mm,z_mm,du_um,dv_um`, plus `temp_c` when the runs
/// carry temperatures and `test` when any run has a label (empty cells for the others).
/// Numbers are written in their shortest form that reads back to the same value.
pub fn write_plane_csv(w: impl Write, runs: &[Run]) -> std::io::Result<()> {
    check_runs(runs)?;
    let temp = runs.first().is_some_and(|r| r.temp_c.is_some());
    let test = runs.iter().any(|r| r.test.is_some());
    let optional = [("temp_c", temp), ("test", test)];
    let names = ["run", "t_s", "x_mm", "y_mm", "z_mm", "du_um", "dv_um"]
        .into_iter()
        .chain(optional.into_iter().filter(|c| c.1).map(|c| c.0));
    let mut out = CsvOut::with_header(w, names)?;
    for r in runs {
        let number = r.number.to_string();
        for i in 0..r.t_s.len() {
            out.text(&number)?;
            let [x, y, z] = r.pos_mm[i];
            out.numbers([r.t_s[i], x, y, z, r.du_um[i], r.dv_um[i]])?;
            if let Some(temps) = &r.temp_c {
                out.number(temps[i])?;
            }
            if test {
                out.text(r.test.map_or("", TestKind::name))?;
            }
            out.end_record()?;
        }
    }
    out.finish()
}

/// The session.json document of a session.
pub fn session_json(session: &Session) -> Value {
    let mut root = serde_json::Map::new();
    root.insert("machine_id".into(), json!(session.machine_id));
    root.insert("measured_at".into(), json!(session.measured_at));
    if let Some(t) = &session.topology {
        let names = |s: &[Axis]| s.iter().map(|a| a.to_string()).collect::<Vec<_>>();
        root.insert(
            "topology".into(),
            json!({"workpiece": names(&t.workpiece), "tool": names(&t.tool)}),
        );
    }
    if let Some(n) = &session.notes {
        root.insert("notes".into(), json!(n));
    }
    // The stated conditions (a temperature taken from the temp_c column is not stated).
    let mut c = session.conditions.clone();
    if c.temperature_source.as_deref() != Some("stated") {
        c.temperature_c = None;
    }
    c.temperature_source = None;
    if let Ok(Value::Object(fields)) = serde_json::to_value(&c) {
        root.extend(fields);
    }
    let planes: Vec<Value> = session
        .planes
        .iter()
        .map(|p| {
            json!({
                "file": p.file,
                "plane": p.plane.name(),
                "head_offset_mm": p.head_offset_mm,
                "mounting": p.mounting,
            })
        })
        .collect();
    root.insert("planes".into(), Value::Array(planes));
    Value::Object(root)
}

/// Writes a session folder (used by `mtcal simulate`): each plane CSV (gzip when its name
/// ends in `.gz`), then `session.json` last, so a folder with a session.json is complete.
/// The session is checked first (file names, finite values, equal column lengths); an
/// invalid session writes nothing.
pub fn write_session_dir(dir: &Path, session: &Session) -> std::io::Result<()> {
    let mut seen = Vec::new();
    for p in &session.planes {
        if !valid_file_name(&p.file) || seen.contains(&&p.file) {
            return Err(invalid_input(format!(
                "invalid or repeated plane file name `{}`",
                p.file
            )));
        }
        seen.push(&p.file);
        // Validate the runs before creating anything.
        check_runs(&p.runs)?;
    }
    std::fs::create_dir_all(dir)?;
    for p in &session.planes {
        let f = std::io::BufWriter::new(std::fs::File::create(dir.join(&p.file))?);
        if p.file.ends_with(".gz") {
            let mut gz = flate2::write::GzEncoder::new(f, flate2::Compression::default());
            write_plane_csv(&mut gz, &p.runs)?;
            gz.finish()?.flush()?;
        } else {
            write_plane_csv(f, &p.runs)?;
        }
    }
    let text =
        serde_json::to_string_pretty(&session_json(session)).map_err(std::io::Error::other)?;
    std::fs::write(dir.join(SESSION_JSON), text + "\n")
}
