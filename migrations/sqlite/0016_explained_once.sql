-- The explained model of a check is stored once: `explains_result_id` names the check
-- (an identification result) an explained model was fitted for, and a unique index
-- lets one result claim it. Of two processes storing one explained model concurrently
-- (the API's and a worker's, two workers), the second insert is refused and stores
-- nothing. Explained models stored before this migration claim their check from their
-- document (`explained.original_result_id`); where two were stored for one check, the
-- first to land keeps the claim and the other stays as it is.
ALTER TABLE results ADD COLUMN explains_result_id TEXT;
UPDATE results
SET explains_result_id = json_extract(document, '$.explained.original_result_id')
WHERE kind = 'identification'
  AND document LIKE '%original_result_id%'
  AND json_extract(document, '$.explained.original_result_id') IS NOT NULL
  AND id = (
    SELECT o.id FROM results o
    WHERE o.kind = 'identification'
      AND o.document LIKE '%original_result_id%'
      AND json_extract(o.document, '$.explained.original_result_id')
        = json_extract(results.document, '$.explained.original_result_id')
    ORDER BY o.created_at, o.id
    LIMIT 1
  );
CREATE UNIQUE INDEX results_explains ON results(explains_result_id);
