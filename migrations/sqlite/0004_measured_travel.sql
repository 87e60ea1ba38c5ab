-- Per result: the travel each axis measured ({"X": [min, max], ...}, mm) and the
-- covariance of each identifiable term's coefficients ({"EXX": [[...], ...], ...}), so
-- that trends, differences and drift are evaluated only where the check measured and
-- carry their standard uncertainty. '{}' for results stored before (unknown).
ALTER TABLE results ADD COLUMN measured_travel TEXT NOT NULL DEFAULT '{}';
ALTER TABLE results ADD COLUMN term_covariance TEXT NOT NULL DEFAULT '{}';
