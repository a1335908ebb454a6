-- Process profiles and their calibrations: a shop's named process, and every calibration
-- fitted to it (newest last). Records are immutable: a correction is a new row. Portable SQL
-- (SQLite and PostgreSQL): text keys, RFC 3339 UTC timestamps as text, JSON bodies as text.
CREATE TABLE process_profiles (
    name TEXT PRIMARY KEY,
    -- The profile as created: process, surface, tool (JSON).
    body TEXT NOT NULL,
    created_at TEXT NOT NULL,
    -- The API key that wrote it (empty when the service runs without keys).
    created_by TEXT NOT NULL
);

CREATE TABLE calibrations (
    id TEXT PRIMARY KEY,
    profile TEXT NOT NULL REFERENCES process_profiles (name),
    -- The request and its answer (JSON).
    request TEXT NOT NULL,
    result TEXT NOT NULL,
    -- Learned from a production cycle rather than asked for.
    learned BOOLEAN NOT NULL,
    created_at TEXT NOT NULL,
    created_by TEXT NOT NULL
);

CREATE INDEX calibrations_by_profile ON calibrations (profile, created_at);
