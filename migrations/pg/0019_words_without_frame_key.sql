-- placedb schema 19 on PostgreSQL: a word's creating frame without a key check (issue 47).
--
-- words.created_frame referenced frames with a deferred key: each of a frame's ~134 new words
-- queued a check run at commit, 0.5-0.8 ms of the server's ~6 ms of CPU per robot frame
-- (bench/fleet/README.md). The writer proves every row by construction, as for word_refs in
-- schema 16: a word's created_frame is the frame the same transaction inserts (NULL for an
-- imported word), and no writer deletes a frame. What SQL by hand could still do (delete a frame
-- whose words remain) `placedb check` finds: it reports every words row whose created_frame is
-- missing (storage/src/postgres/pg_map_check.cpp), as the file's foreign-key stage does.
ALTER TABLE words DROP CONSTRAINT words_created_frame_fkey;
