-- A part's cycles read only the heads of its measurements and plans (ids, figures, links),
-- never their bodies. SQLite keeps a row's columns in order and the bodies come first, so
-- reaching `rms_nm` walked each ~100 kB trace's overflow pages: these covering indexes answer
-- those reads alone (a 100-cycle history: measured in docs/PERFORMANCE.md).
CREATE INDEX measurements_heads ON measurements (part, id, rms_nm, created_at, created_by);
CREATE INDEX plans_heads ON plans (part, id, measurement, predicted_rms_after_nm, created_at, created_by);
