-- A check's model, kept beside its result so a trend, an alert or a fleet row learns it
-- without reading the result's document: `check_gate` is the misfit gate's outcome of an
-- identification (`decided`: its model explains its recording; `misfit`: it does not,
-- its values are not decided; `explained`: decided on the explained model) and
-- `check_statement` the gate's statement for the last two. Written when a result lands.
-- NULL: not known yet (a result stored before this migration, or of another kind); the
-- service fills these at start from the documents, and reads a document until then.
ALTER TABLE results ADD COLUMN check_gate TEXT;
ALTER TABLE results ADD COLUMN check_statement TEXT;
-- The identifications whose model is not known yet (few, after the fill at start).
CREATE INDEX results_check_unknown ON results(id) WHERE check_gate IS NULL AND kind = 'identification';
