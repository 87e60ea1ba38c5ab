-- A result excluded from the history (a bad check: wrong setup, poisoned input): kept for
-- the record, with who excluded it, when and why, but left out of lists, trends, drift,
-- differences and figure trends.
ALTER TABLE results ADD COLUMN excluded_at TEXT;
ALTER TABLE results ADD COLUMN excluded_by TEXT;
ALTER TABLE results ADD COLUMN excluded_reason TEXT;
