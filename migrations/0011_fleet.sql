-- placedb schema 11: fleet maps. A map on a PostgreSQL server may have several writers at once,
-- each in a session of its own (schema/SCHEMA.md, "Fleet maps"). One of them continues the map's
-- main line, whose memory is in the map-wide tables (engine_state, kd_nodes, filter_posterior,
-- locations.tier, wm_entries) as in a file; every other keeps its memory in these per-session
-- tables, a copy of the main line's taken when its session began. A file has one writer and
-- never writes them: they are here so that `placedb copy` carries a fleet map to a file and back.

-- The id allocator of a map with several writers: each writer hands out frame, location and word
-- ids from blocks [first, first + size) it reserves here, so no two writers give one id twice.
CREATE TABLE id_blocks (
  kind TEXT PRIMARY KEY CHECK (kind IN ('frame', 'location', 'word')),
  next INTEGER NOT NULL              -- every id of this kind below it is used or reserved
) WITHOUT ROWID;

-- A session's own engine state (engine_state's writer keys: engine.counters, vocabulary.header,
-- storage.kd_nodes.rows), with the same checksums.
CREATE TABLE session_state (
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  key TEXT NOT NULL,
  value BLOB,
  checksum INTEGER,
  PRIMARY KEY (session_id, key)
) WITHOUT ROWID;

-- A session's own kd-forest (as kd_nodes).
CREATE TABLE session_kd_nodes (
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  tree INTEGER NOT NULL,
  node INTEGER NOT NULL,
  left_child INTEGER NOT NULL,
  right_child INTEGER NOT NULL,
  split_dim INTEGER NOT NULL,
  split_value REAL NOT NULL,
  checksum INTEGER,
  PRIMARY KEY (session_id, tree, node)
) WITHOUT ROWID;

-- A session's own Bayes filter posterior (as filter_posterior: no key on the location, ids <= 0
-- are the virtual "new place").
CREATE TABLE session_posterior (
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  location_id INTEGER NOT NULL,
  probability REAL NOT NULL,
  PRIMARY KEY (session_id, location_id)
) WITHOUT ROWID;

-- The locations in a session's own STM (0) and WM (1), with their age in its transfer order;
-- every other location is in its long-term memory.
CREATE TABLE session_memory (
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  location_id INTEGER NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  tier INTEGER NOT NULL CHECK (tier IN (0, 1)),
  wm_age INTEGER,
  PRIMARY KEY (session_id, location_id)
) WITHOUT ROWID;
