-- Named scalar figures of a result (the standards' figures: iso230_2.X.E_um,
-- iso230_4.XY.bi.H_um, ...), one row each, so that they trend and take tolerances.
-- machine_id, kind and measured_at repeat the result's, so a trend is one index range.
-- The same table as migrations/sqlite/0003_result_figures.sql.
CREATE TABLE result_figures (
    result_id   TEXT COLLATE "C" NOT NULL REFERENCES results(id) ON DELETE CASCADE,
    machine_id  TEXT COLLATE "C" NOT NULL,
    kind        TEXT NOT NULL,
    measured_at TEXT COLLATE "C" NOT NULL,
    name        TEXT COLLATE "C" NOT NULL,
    value       DOUBLE PRECISION NOT NULL,
    u           DOUBLE PRECISION,               -- standard uncertainty (k = 1), NULL if unknown
    PRIMARY KEY (result_id, name)
);
CREATE INDEX result_figures_trend ON result_figures(machine_id, name, measured_at, result_id);
