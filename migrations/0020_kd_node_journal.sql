-- placedb schema 20: a map file's kd-forest changes a frame at a time (schema/SCHEMA.md,
-- "kd_node_journal").
--
-- A frame splits ~100 leaves of the vocabulary's kd-forest, and each split's row sorts where the
-- leaf's id does, anywhere in kd_nodes: writing them as they came rewrote ~90 pages of the table
-- a frame, half of all the pages a frame wrote and ~0.6 ms of a lip6 frame's ~6.6 (issue 47). A
-- frame now appends its changes here as one row and folds into kd_nodes the pending changes of
-- one slice of node ids, rows that sit together (storage/src/sqlite/kd_node_journal.h). The
-- forest is kd_nodes with these rows applied in seq order; a clean close folds them all.
CREATE TABLE kd_node_journal (
  seq INTEGER PRIMARY KEY,
  changes BLOB NOT NULL,             -- deletions then upserts, little-endian records
  checksum INTEGER                   -- CRC-32C of seq and changes
);
