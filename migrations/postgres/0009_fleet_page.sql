-- The fleet page at fleet scale (10 000 machines).
-- `basis` names what a stored fleet row was computed from (the row format, the baseline
-- and latest results, how many results, the tolerance profile and its revision): the
-- refresh at start skips the rows whose basis is still current. NULL: written by an
-- older version, recomputed once.
ALTER TABLE fleet_drift ADD COLUMN basis TEXT;
-- The page sorts every machine by these keys: read from this index, never from the
-- wide rows (a row's entry, with its sparkline, is kilobytes).
CREATE INDEX fleet_drift_keys ON fleet_drift(machine_id, drift_um, drift_urad, latest_measured_at);
-- The machines with active alerts (few) come first on the page.
CREATE INDEX alerts_active ON alerts(machine_id) WHERE acknowledged_at IS NULL;
-- The page's filter choices (every site, every tag list) and its count read these, not
-- the machines' rows.
CREATE INDEX machines_site ON machines(site);
CREATE INDEX machines_tags ON machines(tags);
-- Each machine's current (not excluded) results in time order, from the index alone:
-- how many, its first and its latest (the refresh at start asks this of every machine).
CREATE INDEX results_current ON results(machine_id, kind, measured_at, id)
    WHERE excluded_at IS NULL;
