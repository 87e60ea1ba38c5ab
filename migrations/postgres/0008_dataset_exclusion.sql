-- A dataset excluded (a bad measurement: wrong setup, wrong machine, poisoned input): kept
-- for the record with who, when and why, no longer used for new jobs, left out of default
-- listings; the results computed from it are excluded with the same record.
ALTER TABLE datasets ADD COLUMN excluded_at TEXT;
ALTER TABLE datasets ADD COLUMN excluded_by TEXT;
ALTER TABLE datasets ADD COLUMN excluded_reason TEXT;
-- A dataset whose raw bytes were deleted (an excluded dataset whose files must go): the
-- row and its files' names, sizes and checksums stay as a tombstone with who, when and
-- why; the files' content is emptied.
ALTER TABLE datasets ADD COLUMN deleted_at TEXT;
ALTER TABLE datasets ADD COLUMN deleted_by TEXT;
ALTER TABLE datasets ADD COLUMN deleted_reason TEXT;
-- Excluding a dataset finds its results and its queued or running jobs.
CREATE INDEX results_dataset ON results(dataset_id);
CREATE INDEX jobs_dataset ON jobs(dataset_id, state);
