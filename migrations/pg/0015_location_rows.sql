-- placedb schema 15 on PostgreSQL: what each location's rows must hold, and sums on the WM ages
-- and the posterior (migrations/0015_location_rows.sql says why). The runner fills them in for
-- the rows an older map holds.
ALTER TABLE locations ADD COLUMN held bigint;
ALTER TABLE locations ADD COLUMN refs_digest bigint;
ALTER TABLE locations ADD COLUMN checksum bigint;
ALTER TABLE locations ADD COLUMN link_count bigint;
ALTER TABLE wm_entries ADD COLUMN checksum bigint;
ALTER TABLE filter_posterior ADD COLUMN checksum bigint;
ALTER TABLE sessions ADD COLUMN settings_digest bigint;
