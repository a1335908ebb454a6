-- Parts and their correction cycles: measurements, plans, runs; what a calibration was learned
-- from; and the answers to POSTs sent with an Idempotency-Key. Records are immutable: a
-- correction is a new row. Ids are UUIDv7 (time-ordered text), so `ORDER BY id` is the order in
-- which records were written.
ALTER TABLE calibrations ADD COLUMN preston_coefficient_m2_per_n DOUBLE PRECISION;
ALTER TABLE calibrations ADD COLUMN standard_error_m2_per_n DOUBLE PRECISION;
-- The calibrated process (JSON), as any endpoint takes it.
ALTER TABLE calibrations ADD COLUMN process TEXT;
-- The production run it was learned from (learned calibrations only).
ALTER TABLE calibrations ADD COLUMN run TEXT;

CREATE TABLE parts (
    id TEXT PRIMARY KEY,
    -- The shop's serial.
    name TEXT NOT NULL UNIQUE,
    process_profile TEXT NOT NULL REFERENCES process_profiles (name),
    -- surface, workpiece_radius_mm, clear_aperture (JSON).
    body TEXT NOT NULL,
    created_at TEXT NOT NULL,
    created_by TEXT NOT NULL
);

CREATE TABLE measurements (
    id TEXT PRIMARY KEY,
    part TEXT NOT NULL REFERENCES parts (id),
    -- The /v1/measurement/fit request as run, and its answer (JSON).
    request TEXT NOT NULL,
    result TEXT NOT NULL,
    -- The form error's RMS over the clear aperture.
    rms_nm DOUBLE PRECISION NOT NULL,
    created_at TEXT NOT NULL,
    created_by TEXT NOT NULL
);

CREATE INDEX measurements_by_part ON measurements (part, id);

CREATE TABLE plans (
    id TEXT PRIMARY KEY,
    part TEXT NOT NULL REFERENCES parts (id),
    -- The part's latest measurement when the plan was made (the cycle's "before").
    measurement TEXT REFERENCES measurements (id),
    -- The /v1/optimize request as run, and its answer (JSON).
    request TEXT NOT NULL,
    result TEXT NOT NULL,
    predicted_rms_after_nm DOUBLE PRECISION NOT NULL,
    created_at TEXT NOT NULL,
    created_by TEXT NOT NULL
);

CREATE INDEX plans_by_part ON plans (part, id);

CREATE TABLE runs (
    id TEXT PRIMARY KEY,
    part TEXT NOT NULL REFERENCES parts (id),
    plan TEXT NOT NULL REFERENCES plans (id),
    started_at TEXT NOT NULL,
    finished_at TEXT NOT NULL,
    machine TEXT,
    notes TEXT,
    created_at TEXT NOT NULL,
    created_by TEXT NOT NULL
);

CREATE INDEX runs_by_part ON runs (part, id);

CREATE TABLE idempotency_keys (
    -- The API key that sent it (empty without keys): one client's key never replays another's.
    owner TEXT NOT NULL,
    key TEXT NOT NULL,
    -- SHA-256 of the method, path and body: another request under the same key is refused.
    fingerprint TEXT NOT NULL,
    status BIGINT NOT NULL,
    location TEXT NOT NULL,
    body TEXT NOT NULL,
    created_at TEXT NOT NULL,
    PRIMARY KEY (owner, key)
);
