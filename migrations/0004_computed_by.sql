-- Which code wrote each record: the Preston version, the build's git revision and the records
-- schema (`computed_by`, e.g. "preston 0.1.0 (git 0e2373b4f1c2), records schema 4"). Records
-- written before this migration have '' (unknown).
ALTER TABLE process_profiles ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE calibrations ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE parts ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE measurements ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE plans ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
ALTER TABLE runs ADD COLUMN computed_by TEXT NOT NULL DEFAULT '';
