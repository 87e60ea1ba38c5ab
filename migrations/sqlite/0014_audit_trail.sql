-- The audit trail: one row per change of state a person made through the service (who,
-- what, before and after, when, from where). Append-only: the triggers below refuse
-- every UPDATE and DELETE, whoever sends it.
--
-- `seq` orders the trail and pages it; `at` is the service's clock (RFC 3339 UTC,
-- milliseconds); `actor` is a key id (empty when no key was recognised), `actor_name`
-- its label and prefix then; `via` is `api` or `dashboard`; `before_json` and
-- `after_json` are the target's JSON before and after (NULL: it did not exist, or no
-- longer does); `client` the client's address.
CREATE TABLE audit_events (
    seq         INTEGER PRIMARY KEY AUTOINCREMENT,
    at          TEXT NOT NULL,
    actor       TEXT NOT NULL,
    actor_name  TEXT NOT NULL,
    via         TEXT NOT NULL,
    action      TEXT NOT NULL,
    target      TEXT NOT NULL,
    machine_id  TEXT,
    before_json TEXT,
    after_json  TEXT,
    client      TEXT
);
CREATE INDEX audit_events_machine ON audit_events(machine_id, seq);
CREATE INDEX audit_events_actor ON audit_events(actor, seq);
CREATE INDEX audit_events_action ON audit_events(action, seq);
CREATE INDEX audit_events_at ON audit_events(at);

CREATE TRIGGER audit_events_no_update BEFORE UPDATE ON audit_events
BEGIN
    SELECT RAISE(ABORT, 'audit_events is append-only: a row is never updated');
END;
CREATE TRIGGER audit_events_no_delete BEFORE DELETE ON audit_events
BEGIN
    SELECT RAISE(ABORT, 'audit_events is append-only: a row is never deleted');
END;
