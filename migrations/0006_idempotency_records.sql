-- An Idempotency-Key's claim names the record its write created (`record_id`); a retry is
-- answered by rendering that record as the first answer showed it, so the claim no longer
-- keeps the answer's body ('' from now on; claims written before keep theirs and are
-- answered with it).
ALTER TABLE idempotency_keys ADD COLUMN record_id TEXT NOT NULL DEFAULT '';
