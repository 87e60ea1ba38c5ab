-- The fleet page walks an index in its order and stops once the page is full: by
-- drift (fleet_drift_um, fleet_drift_urad, migration 0005), by machine id (the
-- machines' key) and, here, by the latest check.
CREATE INDEX fleet_drift_last_check ON fleet_drift(latest_measured_at DESC, machine_id);
-- The sort keys of every machine are no longer read together (no sort of the whole fleet).
DROP INDEX fleet_drift_keys;
