-- placedb schema 23 on PostgreSQL: a side session's own memory no longer has a key on its session.
--
-- session_state, session_kd_nodes and session_memory checked each row's session_id against
-- sessions, one lookup a row: the ~100 kd-forest rows of every frame of a side writer, and the
-- whole forest of the main line (~75k rows at lip6's 540 frames) that a side session copies when
-- it begins (copyMainLineMemory: ~0.36 s of server time each). A writer writes these rows only
-- for the session it began, in that session's first transaction, and no writer deletes a
-- session; placedb check reports rows whose session is missing. session_memory keeps its key on
-- the location: a place deleted takes its rows with it.
ALTER TABLE session_state DROP CONSTRAINT session_state_session_id_fkey;
ALTER TABLE session_kd_nodes DROP CONSTRAINT session_kd_nodes_session_id_fkey;
ALTER TABLE session_memory DROP CONSTRAINT session_memory_session_id_fkey;
