-- Per-machine, per-kind time order: first/last result and counts by index seeks only
-- (history, trend and fleet queries).
CREATE INDEX results_machine_kind_time ON results(machine_id, kind, measured_at, id);
