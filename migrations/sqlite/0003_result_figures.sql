-- Named scalar figures of a result (the standards' figures: iso230_2.X.E_um,
-- iso230_4.XY.bi.H_um, ...), one row each, so that they trend and take tolerances.
-- machine_id, kind and measured_at repeat the result's, so a trend is one index range.
CREATE TABLE result_figures (
    result_id   TEXT NOT NULL REFERENCES results(id) ON DELETE CASCADE,
    machine_id  TEXT NOT NULL,
    kind        TEXT NOT NULL,
    measured_at TEXT NOT NULL,
    name        TEXT NOT NULL,
    value       REAL NOT NULL,
    u           REAL,                           -- standard uncertainty (k = 1), NULL if unknown
    PRIMARY KEY (result_id, name)
);
CREATE INDEX result_figures_trend ON result_figures(machine_id, name, measured_at, result_id);
