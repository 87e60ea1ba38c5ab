-- mtcal service schema (SQLite). Times shown to users are RFC 3339 UTC text; times the
-- queue compares are integer milliseconds since the Unix epoch.

CREATE TABLE machines (
    id                 TEXT PRIMARY KEY,
    name               TEXT NOT NULL,
    topology           TEXT NOT NULL,          -- JSON {"workpiece": [...], "tool": [...]}
    travel_mm          TEXT NOT NULL,          -- JSON {"X": [min, max], ...}
    site               TEXT,
    tags               TEXT NOT NULL DEFAULT '[]',
    baseline_result_id TEXT,                   -- NULL: the machine's first result
    created_at         TEXT NOT NULL,
    updated_at         TEXT NOT NULL
);

CREATE TABLE datasets (
    id           TEXT PRIMARY KEY,
    machine_id   TEXT NOT NULL REFERENCES machines(id),
    kind         TEXT NOT NULL,                -- 'session'
    measured_at  TEXT NOT NULL,
    uploaded_at  TEXT NOT NULL,
    samples      INTEGER NOT NULL,
    total_bytes  INTEGER NOT NULL,
    sha256       TEXT NOT NULL                 -- over the sorted (name, file sha256) list
);
CREATE INDEX datasets_machine ON datasets(machine_id, measured_at);

CREATE TABLE dataset_files (
    dataset_id TEXT NOT NULL REFERENCES datasets(id) ON DELETE CASCADE,
    name       TEXT NOT NULL,
    sha256     TEXT NOT NULL,
    size       INTEGER NOT NULL,
    content    BLOB NOT NULL,                  -- the bytes as uploaded (gzip kept as is)
    PRIMARY KEY (dataset_id, name)
);

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY,
    seq              INTEGER NOT NULL,         -- submission order
    kind             TEXT NOT NULL,
    machine_id       TEXT REFERENCES machines(id),
    dataset_id       TEXT REFERENCES datasets(id),
    params           TEXT NOT NULL,            -- JSON
    state            TEXT NOT NULL,            -- queued | running | succeeded | failed | cancelled
    progress         REAL NOT NULL DEFAULT 0,
    progress_message TEXT,
    attempts         INTEGER NOT NULL DEFAULT 0,
    max_attempts     INTEGER NOT NULL,
    run_after_ms     INTEGER NOT NULL,
    lease_owner      TEXT,
    lease_expires_ms INTEGER,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    error_code       TEXT,
    error_message    TEXT,
    result_id        TEXT,
    created_at       TEXT NOT NULL,
    started_at       TEXT,
    finished_at      TEXT
);
CREATE INDEX jobs_claim ON jobs(state, run_after_ms, seq);
CREATE INDEX jobs_lease ON jobs(state, lease_expires_ms);

CREATE TABLE results (
    id               TEXT PRIMARY KEY,
    job_id           TEXT NOT NULL UNIQUE REFERENCES jobs(id),
    machine_id       TEXT NOT NULL REFERENCES machines(id),
    dataset_id       TEXT REFERENCES datasets(id),
    kind             TEXT NOT NULL,
    measured_at      TEXT NOT NULL,
    created_at       TEXT NOT NULL,
    document         TEXT NOT NULL,            -- the result document (results contract)
    -- Scalars for trend queries (NULL when not determined by the data).
    residual_rms_um  REAL,
    condition_number REAL,
    rank             INTEGER,
    ec0y_urad        REAL,
    eb0z_urad        REAL,
    ea0z_urad        REAL,
    -- JSON {"EXX": [c1, c2, c3], ...}: monomial coefficients of the identifiable terms.
    term_coefficients TEXT NOT NULL DEFAULT '{}'
);
CREATE INDEX results_machine_time ON results(machine_id, measured_at, id);

CREATE TABLE api_keys (
    id         TEXT PRIMARY KEY,
    hash       TEXT NOT NULL UNIQUE,           -- SHA-256 of the whole key, hex
    prefix     TEXT NOT NULL,                  -- first characters, to recognise a key
    scope      TEXT NOT NULL,                  -- read | write | admin
    label      TEXT NOT NULL,
    created_at TEXT NOT NULL,
    revoked_at TEXT
);
