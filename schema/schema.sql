-- placedb map schema: the current version (13), as one file.
-- It must equal the result of applying migrations/0001..N in order; a test compares
-- sqlite_master of both. `sqlite3 new.db < schema/schema.sql` makes an empty placedb map.
-- See schema/SCHEMA.md for the meaning of every table, column and view.
BEGIN;
-- One run of the engine over one image source.
CREATE TABLE sessions (
  id INTEGER PRIMARY KEY,
  started_at TEXT NOT NULL,          -- ISO 8601 UTC
  ended_at TEXT,                     -- NULL while running or after a crash
  clean_close INTEGER NOT NULL DEFAULT 0 CHECK (clean_close IN (0, 1)),
  software_version TEXT NOT NULL,
  source TEXT NOT NULL,
  source_digest TEXT,                -- what the source held at the start (schema 6); NULL: unknown
  settings_digest INTEGER            -- CRC-32C of its settings rows (schema 15)
);

-- The settings a session ran with, as text.
CREATE TABLE settings (
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  key TEXT NOT NULL,
  value TEXT NOT NULL,
  PRIMARY KEY (session_id, key)
) WITHOUT ROWID;

-- Every input frame, including the ones rejected as bad.
CREATE TABLE frames (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  source_index INTEGER NOT NULL,
  source_path TEXT,
  outcome INTEGER NOT NULL CHECK (outcome IN (0, 1, 2)),  -- 0 new location, 1 merged, 2 bad
  location_id INTEGER REFERENCES locations (id) ON DELETE SET NULL DEFERRABLE INITIALLY DEFERRED,
  features_ms REAL,
  quantisation_ms REAL,
  likelihood_ms REAL,
  filter_ms REAL,
  memory_ms REAL,
  storage_ms REAL,
  total_ms REAL,
  feature_count INTEGER,
  words_created INTEGER,
  vocabulary_size INTEGER,
  wm_size INTEGER,
  stm_size INTEGER,
  mean_quantisation_error REAL,
  stamp_ns INTEGER,                  -- the source's time stamp, ns since the epoch (schema 9)
  UNIQUE (session_id, source_index)
);
CREATE INDEX frames_by_location ON frames (location_id);

-- Places of the map. Ids are assigned by the engine.
CREATE TABLE locations (
  id INTEGER PRIMARY KEY,
  session_id INTEGER NOT NULL REFERENCES sessions (id),
  weight INTEGER NOT NULL DEFAULT 0,
  tier INTEGER NOT NULL CHECK (tier IN (0, 1, 2)),  -- 0 STM, 1 WM, 2 LTM
  created_frame INTEGER REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  held INTEGER,                      -- which of its rows exist, bits (schema 15; see SCHEMA.md)
  refs_digest INTEGER,               -- CRC-32C of its word_refs rows (schema 15)
  checksum INTEGER,                  -- CRC-32C of id, session_id, weight, created_frame (schema 15)
  link_count INTEGER                 -- links naming it (schema 15)
);
CREATE INDEX locations_by_session ON locations (session_id);
CREATE INDEX locations_by_created_frame ON locations (created_frame);  -- schema 12

-- Which frames a location stands for (several after STM merging).
CREATE TABLE location_frames (
  location_id INTEGER NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  frame_id INTEGER NOT NULL REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  PRIMARY KEY (location_id, frame_id)
) WITHOUT ROWID;
CREATE INDEX location_frames_by_frame ON location_frames (frame_id);

-- Vocabulary files imported into the map.
CREATE TABLE vocabulary_imports (
  id INTEGER PRIMARY KEY,
  session_id INTEGER REFERENCES sessions (id),
  file TEXT NOT NULL,
  checksum TEXT NOT NULL,
  word_count INTEGER NOT NULL,
  mode TEXT NOT NULL CHECK (mode IN ('fixed', 'seed')),
  imported_at TEXT NOT NULL,         -- ISO 8601 UTC
  extractor TEXT,                    -- as the file's header names them (schema 2)
  distance_unit TEXT,
  settings TEXT                      -- JSON object, key -> value
);

-- Visual words. descriptor holds dim values of the given type, little-endian.
CREATE TABLE words (
  id INTEGER PRIMARY KEY,
  created_frame INTEGER REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  vocabulary_import_id INTEGER REFERENCES vocabulary_imports (id),
  descriptor_type INTEGER NOT NULL CHECK (descriptor_type IN (0, 1)),  -- 0 float32, 1 uint8
  dim INTEGER NOT NULL CHECK (dim > 0),
  descriptor BLOB NOT NULL
    CHECK (length(descriptor) = dim * (CASE descriptor_type WHEN 0 THEN 4 ELSE 1 END)),
  source_frame INTEGER,              -- imported words: creating frame in their source map
  checksum INTEGER                   -- CRC-32C of the row (schema 8; see SCHEMA.md)
);
CREATE INDEX words_by_created_frame ON words (created_frame);
-- Imported words only (schema 2): read on every open, so kept apart from the whole vocabulary.
CREATE INDEX words_imported ON words (id) WHERE vocabulary_import_id IS NOT NULL;

-- The signature of each location: one row per keypoint, in signature order.
CREATE TABLE word_refs (
  location_id INTEGER NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  ordinal INTEGER NOT NULL,
  word_id INTEGER NOT NULL REFERENCES words (id),
  x REAL NOT NULL,
  y REAL NOT NULL,
  size REAL NOT NULL,
  angle REAL NOT NULL,
  response REAL NOT NULL,
  PRIMARY KEY (location_id, ordinal)
) WITHOUT ROWID;

-- Graph edges, stored once per unordered pair and type (location_a < location_b).
CREATE TABLE links (
  location_a INTEGER NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  location_b INTEGER NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  type INTEGER NOT NULL CHECK (type IN (0, 1, 2)),  -- 0 neighbour, 1 loop closure, 2 merge
  score REAL,
  PRIMARY KEY (location_a, location_b, type),
  CHECK (location_a < location_b)
) WITHOUT ROWID;
CREATE INDEX links_by_b ON links (location_b);

-- The best loop-closure hypothesis of each frame.
CREATE TABLE hypotheses (
  frame_id INTEGER PRIMARY KEY REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  best_location_id INTEGER REFERENCES locations (id) ON DELETE SET NULL,
  posterior REAL NOT NULL,
  loop_probability REAL NOT NULL,
  accepted INTEGER NOT NULL CHECK (accepted IN (0, 1)),
  rejected_reason TEXT,
  -- Schema 7: an accepted closure's relative pose where the session has intrinsics, else NULL:
  -- the frame's camera in the camera of best_location_id, rotation as a unit quaternion and
  -- unit translation direction (no scale), and the pairs that agreed with the essential matrix.
  pose_qw REAL,
  pose_qx REAL,
  pose_qy REAL,
  pose_qz REAL,
  pose_tx REAL,
  pose_ty REAL,
  pose_tz REAL,
  pose_inliers INTEGER
);
CREATE INDEX hypotheses_by_location ON hypotheses (best_location_id);

-- Engine state needed for an exact resume.
CREATE TABLE engine_state (
  key TEXT PRIMARY KEY,
  value BLOB,
  checksum INTEGER                   -- CRC-32C of key and value (schema 8)
) WITHOUT ROWID;

-- The vocabulary's kd-forest: its internal nodes, updated every frame. A node id that is not a
-- row is a leaf when a row names it as a child (or it is the root, node 0), free otherwise.
CREATE TABLE kd_nodes (
  tree INTEGER NOT NULL CHECK (tree >= 0),
  node INTEGER NOT NULL CHECK (node >= 0),
  left_child INTEGER NOT NULL,
  right_child INTEGER NOT NULL,
  split_dim INTEGER NOT NULL,
  split_value REAL NOT NULL,
  checksum INTEGER,                  -- CRC-32C of the row (schema 8)
  PRIMARY KEY (tree, node)
) WITHOUT ROWID;

-- The kd-forest's latest changes, a row a frame (schema 20): the forest is kd_nodes with these
-- applied in seq order; a clean close folds them into kd_nodes.
CREATE TABLE kd_node_journal (
  seq INTEGER PRIMARY KEY,
  changes BLOB NOT NULL,             -- deletions then upserts, little-endian records
  checksum INTEGER                   -- CRC-32C of seq and changes
);

-- The Bayes filter posterior after the last committed frame. location_id has no
-- foreign key on purpose: ids <= 0 stand for the filter's virtual "new place".
CREATE TABLE filter_posterior (
  location_id INTEGER PRIMARY KEY,
  probability REAL NOT NULL,
  checksum INTEGER                   -- CRC-32C of location_id and probability (schema 15)
);

-- Views for people reading a map with sqlite3.
CREATE VIEW v_frames AS
SELECT f.id AS frame_id, f.session_id, f.source_index, f.source_path,
       CASE f.outcome WHEN 0 THEN 'new' WHEN 1 THEN 'merged' ELSE 'bad' END AS outcome,
       f.location_id, f.feature_count, f.words_created, f.vocabulary_size, f.wm_size, f.stm_size,
       f.mean_quantisation_error, f.features_ms, f.quantisation_ms, f.likelihood_ms, f.filter_ms,
       f.memory_ms, f.storage_ms, f.total_ms, f.stamp_ns
FROM frames f;

CREATE VIEW v_locations AS
SELECT l.id AS location_id, l.session_id, l.weight,
       CASE l.tier WHEN 0 THEN 'STM' WHEN 1 THEN 'WM' ELSE 'LTM' END AS tier,
       l.created_frame,
       (SELECT count(*) FROM word_refs r WHERE r.location_id = l.id) AS word_ref_count,
       (SELECT count(*) FROM location_frames lf WHERE lf.location_id = l.id) AS frame_count
FROM locations l;

CREATE VIEW v_location_frames AS
SELECT lf.location_id, lf.frame_id, f.session_id, f.source_index, f.source_path
FROM location_frames lf JOIN frames f ON f.id = lf.frame_id;

CREATE VIEW v_location_words AS
SELECT location_id, word_id, count(*) AS occurrences
FROM word_refs GROUP BY location_id, word_id;

CREATE VIEW v_links AS
SELECT location_a, location_b,
       CASE type WHEN 0 THEN 'neighbour' WHEN 1 THEN 'loop_closure' ELSE 'merge' END AS type,
       score
FROM links;

CREATE VIEW v_loop_closures AS
SELECT k.location_a, k.location_b, k.score,
       (SELECT min(fa.source_index) FROM location_frames lfa JOIN frames fa ON fa.id = lfa.frame_id
         WHERE lfa.location_id = k.location_a) AS first_frame_a,
       (SELECT min(fb.source_index) FROM location_frames lfb JOIN frames fb ON fb.id = lfb.frame_id
         WHERE lfb.location_id = k.location_b) AS first_frame_b,
       (SELECT la.session_id FROM locations la WHERE la.id = k.location_a) AS session_a,
       (SELECT lb.session_id FROM locations lb WHERE lb.id = k.location_b) AS session_b
FROM links k WHERE k.type = 1;

CREATE VIEW v_hypotheses AS
SELECT h.frame_id, f.session_id, f.source_index, h.best_location_id, h.posterior,
       h.loop_probability, h.accepted, h.rejected_reason
FROM hypotheses h JOIN frames f ON f.id = h.frame_id;

CREATE VIEW v_vocabulary_growth AS
SELECT f.session_id, f.source_index, f.id AS frame_id, f.words_created, f.vocabulary_size
FROM frames f;

CREATE VIEW v_kd_trees AS
SELECT tree, count(*) AS internal_nodes, count(*) + 1 AS leaves,
       count(DISTINCT split_dim) AS split_dimensions
FROM kd_nodes GROUP BY tree;

-- Accepted loop closures that carry a relative pose (schema 7).
CREATE VIEW v_loop_closure_poses AS
SELECT h.frame_id, f.session_id, f.source_index, f.location_id, h.best_location_id,
       h.pose_qx, h.pose_qy, h.pose_qz, h.pose_qw, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers
FROM hypotheses h JOIN frames f ON f.id = h.frame_id
WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL;

-- Place codes: a compact global descriptor of every location, in every tier (signed bytes).
CREATE TABLE place_codes (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  code BLOB NOT NULL,
  checksum INTEGER                   -- CRC-32C of location_id and code (schema 8)
);

-- The order in which locations entered STM/WM (a location retrieved from LTM enters again): the
-- transfer order's age. A location without a row (made before schema 4) has its id as age.
CREATE TABLE wm_entries (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  wm_age INTEGER NOT NULL,
  checksum INTEGER                   -- CRC-32C of location_id and wm_age (schema 15)
);

-- Fleet maps (schema 11): several writers of a map on a PostgreSQL server, each in a session
-- of its own; the main line's memory stays in the tables above (SCHEMA.md, "Fleet maps").
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

-- The descriptors of each location's words, stored beside it (schema 13): bringing the location
-- back from long-term memory reads this one row instead of its words scattered over the words
-- table. Copies of words rows, written with the location and never changed; `words` holds, for
-- the location's distinct words that were not imported, ascending: every word id (int64), then
-- every created frame (int64, -1 for none), then every descriptor (dim float32), little-endian.
CREATE TABLE location_word_descriptors (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  dim INTEGER NOT NULL CHECK (dim > 0),
  words BLOB NOT NULL CHECK (length(words) % (16 + 4 * dim) = 0),
  checksum INTEGER                   -- CRC-32C of location_id, dim and words
);

-- kd_nodes' row count, with its CRC-32C (schema 8): an empty map has no kd-forest nodes.
INSERT INTO engine_state (key, value, checksum) VALUES ('storage.kd_nodes.rows', '0', 4094527944);

-- 0x504C4442 = 'PLDB' marks a placedb map; user_version is the schema version.
PRAGMA application_id = 1347175490;
PRAGMA user_version = 23;
COMMIT;
