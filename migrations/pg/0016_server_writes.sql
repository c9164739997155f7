-- placedb schema 16 on PostgreSQL: a frame's writes without work the server never needed
-- (issue 47; bench/fleet/README.md has the figures).
--
-- word_refs no longer references words nor locations: each key checked each of a frame's ~300
-- new references with a query of its own (together most of the references' insert). The writer
-- proves every row by construction: a reference names the location the same transaction inserts
-- just before (or one of the writer's own), and a word of the engine's vocabulary, which holds
-- only words written before or in the same transaction; no writer deletes a word, and the store
-- deletes a location's references with it (deleteLocation, where ON DELETE CASCADE did it).
-- Deletes of words and references are the owner's alone (placedb_guard_table of 0015), and a
-- robot's reference to a location not of its sessions, or of none, is still refused by its
-- guard. What SQL by hand could still do (delete a referenced word or location) `placedb check`
-- finds: it reports every word_refs row whose word or location is missing
-- (storage/src/postgres/pg_map_check.cpp), as the file's foreign-key stage does for a file.
ALTER TABLE word_refs DROP CONSTRAINT word_refs_word_id_fkey,
  DROP CONSTRAINT word_refs_location_id_fkey;

-- Large BLOBs stored out of line without compression: a location's word descriptors (~70 kB) and
-- keypoint descriptors (~18 kB, engine_state) are float32 values pglz cannot shrink, yet it tried
-- on every write, most of the cost of writing them (about 0.9 ms a row on the bench machine
-- against 0.2 ms without). A map written before keeps its rows as they are.
ALTER TABLE location_word_descriptors ALTER COLUMN words SET STORAGE EXTERNAL;
ALTER TABLE engine_state ALTER COLUMN value SET STORAGE EXTERNAL;
ALTER TABLE session_state ALTER COLUMN value SET STORAGE EXTERNAL;
