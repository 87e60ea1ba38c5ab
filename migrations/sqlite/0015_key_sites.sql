-- Sites and roles: a key (and the dashboard sessions signed in with it) acts on the
-- whole group, or on the machines of a list of sites, optionally only those with one of
-- a list of tags. Both are JSON lists of strings; '[]' means no limit of that kind, so
-- every key created before this migration keeps the whole group. A machine whose `site`
-- is NULL is in the site `default` (the rule is applied by the service, not stored).
ALTER TABLE api_keys ADD COLUMN sites TEXT NOT NULL DEFAULT '[]';
ALTER TABLE api_keys ADD COLUMN tags TEXT NOT NULL DEFAULT '[]';
