-- Drift alerts: what each change is the difference of (the baseline's and the landed
-- check's values with the dates they were measured, JSON; absent for alerts raised
-- before this version) and the comment given with an acknowledgement.
ALTER TABLE alerts ADD COLUMN details TEXT;
ALTER TABLE alerts ADD COLUMN acknowledgement_comment TEXT;
