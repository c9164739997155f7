-- placedb schema 8: a CRC-32C beside every BLOB and every row of resume state.
-- SQLite's page checks do not look inside a BLOB, so a changed byte in a word's descriptor or in
-- the engine's state is invisible to them. Each row now carries the CRC-32C of its key and
-- payload (storage/src/row_checksums.cpp gives the exact bytes summed), written with the row and
-- compared when it is read; engine_state's 'storage.kd_nodes.rows' holds kd_nodes' row count, so
-- a deleted node is found too. placedb fills both in for every existing row in this migration's
-- transaction (the sums need code, not SQL).
ALTER TABLE words ADD COLUMN checksum INTEGER;
ALTER TABLE place_codes ADD COLUMN checksum INTEGER;
ALTER TABLE engine_state ADD COLUMN checksum INTEGER;
ALTER TABLE kd_nodes ADD COLUMN checksum INTEGER;
