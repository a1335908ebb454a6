-- A measurement may be an interferometer map: the file as the instrument wrote it is kept as
-- a blob (its SHA-256 here), its analysis is the record's result. NULL for a probe trace.
ALTER TABLE measurements ADD COLUMN map_sha256 TEXT REFERENCES blobs (sha256);
