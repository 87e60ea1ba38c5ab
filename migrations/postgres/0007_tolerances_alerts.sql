-- Tolerance profiles: limits a machine's results are judged against (per machine, or per
-- tag for a group of machines; a machine's own profile wins over its tags'). `limits` is
-- the JSON of the solver's tolerance limits (terms, squareness, standards' figures, drift
-- thresholds); `webhook_url` (tag profiles only) receives the drift alerts of the tag's
-- machines.
CREATE TABLE tolerance_profiles (
    id          TEXT PRIMARY KEY,
    scope       TEXT NOT NULL CHECK (scope IN ('machine', 'tag')),
    target      TEXT NOT NULL,
    limits      TEXT NOT NULL,
    webhook_url TEXT,
    created_at  TEXT NOT NULL,
    updated_at  TEXT NOT NULL,
    UNIQUE (scope, target)
);

-- Drift alerts: raised when a result lands whose change since the machine's baseline
-- exceeds the profile's drift threshold by more than the expanded uncertainty. One per
-- landed result at most; active until acknowledged (who and when recorded). The profile
-- is named, not referenced: it may be deleted later, the alert stays as raised.
CREATE TABLE alerts (
    id                 TEXT PRIMARY KEY,
    machine_id         TEXT NOT NULL REFERENCES machines(id),
    result_id          TEXT NOT NULL UNIQUE REFERENCES results(id),
    baseline_result_id TEXT NOT NULL,
    profile_id         TEXT NOT NULL,
    raised_at          TEXT NOT NULL,
    message            TEXT NOT NULL,
    items              TEXT NOT NULL,
    acknowledged_at    TEXT,
    acknowledged_by    TEXT
);
CREATE INDEX alerts_machine ON alerts(machine_id, raised_at);
CREATE INDEX alerts_raised ON alerts(raised_at);

-- The fleet page sorts by the latest check's time in the database.
ALTER TABLE fleet_drift ADD COLUMN latest_measured_at TEXT;
