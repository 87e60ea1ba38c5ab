-- The explained model of a check is stored once: `explains_result_id` names the check
-- (an identification result) an explained model was fitted for, and a unique index
-- lets one result claim it. Of two processes storing one explained model concurrently
-- (the API's and a worker's, two workers), the second insert is refused and stores
-- nothing. Explained models stored before this migration claim their check from their
-- document (`explained.original_result_id`); where two were stored for one check, the
-- first to land keeps the claim and the other stays as it is.
ALTER TABLE results ADD COLUMN explains_result_id TEXT;
UPDATE results r
SET explains_result_id = f.original
FROM (
    SELECT DISTINCT ON (original) id, original
    FROM (
        SELECT id, created_at,
               document::jsonb #>> '{explained,original_result_id}' AS original
        FROM results
        WHERE kind = 'identification' AND document LIKE '%original_result_id%'
    ) x
    WHERE original IS NOT NULL
    ORDER BY original, created_at, id
) f
WHERE r.id = f.id;
CREATE UNIQUE INDEX results_explains ON results(explains_result_id);
