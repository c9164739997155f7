-- placedb schema 15: what each location's rows must hold, so that a row deleted or added with
-- plain SQL is found as a changed one is. Row checksums (schema 8) see a changed row; a missing one
-- leaves no sum to fail. A location now records which of its rows exist (held: 1 its place code,
-- 2 its word descriptors, 4 its keypoint descriptors in engine_state, 8 its wm_entries row), a
-- CRC-32C of its word references (refs_digest), one of its own row (checksum: its weight) and
-- the number of its links (link_count); the filter's posterior and the WM ages, resume
-- state without sums until now, get one per row, and a session a digest of its settings rows
-- (a setting deleted would resume the session with its default). The runner fills them in for the rows an older
-- map holds (storage/src/location_rows.cpp).
ALTER TABLE locations ADD COLUMN held INTEGER;
ALTER TABLE locations ADD COLUMN refs_digest INTEGER;
ALTER TABLE locations ADD COLUMN checksum INTEGER;
ALTER TABLE locations ADD COLUMN link_count INTEGER;
ALTER TABLE wm_entries ADD COLUMN checksum INTEGER;
ALTER TABLE filter_posterior ADD COLUMN checksum INTEGER;
ALTER TABLE sessions ADD COLUMN settings_digest INTEGER;
