-- Webhook secrets and the delivery outbox.
--
-- `webhook_secret` (tag profiles with a webhook): the key of the HMAC-SHA256 signature
-- of every delivery; written by the API, never read back by it.
ALTER TABLE tolerance_profiles ADD COLUMN webhook_secret TEXT;

-- One row per drift alert and webhook to tell, written in the same transaction as the
-- alert and delivered by the workers: `pending` until a try is answered 2xx
-- (`delivered`) or the tries are used up (`failed`). `next_attempt_ms` is the
-- database's clock (milliseconds since the Unix epoch); a claimed try moves it past
-- its time limit, so that a try whose worker died is made again. `body` is the JSON
-- POSTed, byte for byte what the signature covers.
CREATE TABLE webhook_deliveries (
    id              TEXT PRIMARY KEY,
    alert_id        TEXT NOT NULL REFERENCES alerts(id),
    profile_id      TEXT NOT NULL,
    url             TEXT NOT NULL,
    body            TEXT NOT NULL,
    state           TEXT NOT NULL CHECK (state IN ('pending', 'delivered', 'failed')),
    attempts        INTEGER NOT NULL DEFAULT 0,
    next_attempt_ms BIGINT NOT NULL,
    last_error      TEXT,
    created_at      TEXT NOT NULL,
    updated_at      TEXT NOT NULL,
    UNIQUE (alert_id, profile_id)
);
CREATE INDEX webhook_deliveries_due ON webhook_deliveries(state, next_attempt_ms);
CREATE INDEX webhook_deliveries_created ON webhook_deliveries(created_at);
