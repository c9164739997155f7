-- placedb schema 22 on PostgreSQL: words lose their index by creating frame.
--
-- words_by_created_frame served the foreign key of words.created_frame, which schema 19 dropped
-- on a server (migrations/pg/0019). Nothing reads words by their frame since (check's search
-- for a word whose frame is missing reads every word), and each of a frame's ~134 new words
-- still paid an entry in it: 0.1-0.2 ms of the server's ~5 ms of CPU a robot frame
-- (bench/fleet/statements.sh, issue 47). A map file keeps its index: SQLite's deferred key
-- check looks up the words a new frame row resolves through it.
DROP INDEX words_by_created_frame;
