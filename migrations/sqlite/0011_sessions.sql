-- Sign-in sessions of the dashboard, kept by the database: the session cookie holds a
-- random token whose SHA-256 is the row's key. Signing out deletes the row; a revoked
-- key's sessions are deleted with the revocation (and a session of a revoked key is
-- never read). Expiry is by the database's clock (milliseconds since the Unix epoch).
CREATE TABLE sessions (
    token_hash TEXT PRIMARY KEY,
    key_id     TEXT NOT NULL REFERENCES api_keys(id),
    csrf       TEXT NOT NULL,
    created_ms INTEGER NOT NULL,
    expires_ms INTEGER NOT NULL
);
CREATE INDEX sessions_key ON sessions(key_id);
CREATE INDEX sessions_expiry ON sessions(expires_ms);
