-- Blobs: bytes kept once under their SHA-256 (hex), for what is too big to live inside a
-- record's JSON (an interferometer map is ~20 MB). BYTEA is PostgreSQL's binary type; SQLite
-- keeps the bytes as a BLOB whatever the column's declared type.
CREATE TABLE blobs (
    sha256 TEXT PRIMARY KEY,
    size_bytes BIGINT NOT NULL,
    bytes BYTEA NOT NULL,
    created_at TEXT NOT NULL
);
