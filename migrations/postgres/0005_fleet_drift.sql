-- Drift since the baseline, per machine, maintained when a result lands or the baseline
-- changes (the fleet ranking reads it instead of recomputing every machine per request).
-- `entry` is the ranking's JSON entry (ids, result count, drift and its uncertainty);
-- `read_at_ms` is when the state it was computed from was read: a write computed from an
-- older read than the stored one is ignored, so concurrent workers cannot leave a stale row.
CREATE TABLE fleet_drift (
    machine_id  TEXT PRIMARY KEY REFERENCES machines(id),
    read_at_ms  BIGINT NOT NULL,
    drift_um    DOUBLE PRECISION NOT NULL,
    drift_urad  DOUBLE PRECISION NOT NULL,
    entry       TEXT NOT NULL
);
CREATE INDEX fleet_drift_um ON fleet_drift(drift_um DESC, machine_id);
CREATE INDEX fleet_drift_urad ON fleet_drift(drift_urad DESC, machine_id);
