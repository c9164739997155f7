-- placedb map schema on PostgreSQL, version 9: the tables and views of the SQLite schema at
-- version 9 (migrations/0001..0009), in one script. PostgreSQL maps begin at schema 9, so both
-- backends share one version number: a later migration NNNN_what.sql is written twice, once in
-- migrations/ and once here in migrations/pg/, with the same number.
-- The migration runner wraps this script in one transaction and records the version in
-- placedb_meta. Types: ids and counts bigint, reals double precision (SQLite's REAL), BLOBs
-- bytea; times ISO 8601 UTC text, as in the SQLite map, so both give the same rows.

-- What marks a placedb map (SQLite keeps these in PRAGMA application_id and user_version).
CREATE TABLE placedb_meta (
  key text PRIMARY KEY,
  value text NOT NULL
);

CREATE TABLE sessions (
  id bigint PRIMARY KEY,
  started_at text NOT NULL,
  ended_at text,
  clean_close bigint NOT NULL DEFAULT 0 CHECK (clean_close IN (0, 1)),
  software_version text NOT NULL,
  source text NOT NULL,
  source_digest text
);

CREATE TABLE settings (
  session_id bigint NOT NULL REFERENCES sessions (id),
  key text NOT NULL,
  value text NOT NULL,
  PRIMARY KEY (session_id, key)
);

CREATE TABLE frames (
  id bigint PRIMARY KEY,
  session_id bigint NOT NULL REFERENCES sessions (id),
  source_index bigint NOT NULL,
  source_path text,
  outcome bigint NOT NULL CHECK (outcome IN (0, 1, 2)),
  location_id bigint,
  features_ms double precision,
  quantisation_ms double precision,
  likelihood_ms double precision,
  filter_ms double precision,
  memory_ms double precision,
  storage_ms double precision,
  total_ms double precision,
  feature_count bigint,
  words_created bigint,
  vocabulary_size bigint,
  wm_size bigint,
  stm_size bigint,
  mean_quantisation_error double precision,
  stamp_ns bigint,
  UNIQUE (session_id, source_index)
);
CREATE INDEX frames_by_location ON frames (location_id);

CREATE TABLE locations (
  id bigint PRIMARY KEY,
  session_id bigint NOT NULL REFERENCES sessions (id),
  weight bigint NOT NULL DEFAULT 0,
  tier bigint NOT NULL CHECK (tier IN (0, 1, 2)),
  created_frame bigint REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED
);
CREATE INDEX locations_by_tier ON locations (tier, weight);
CREATE INDEX locations_by_session ON locations (session_id);
-- Added after locations exists (frames and locations reference each other).
ALTER TABLE frames ADD CONSTRAINT frames_location_id_fkey FOREIGN KEY (location_id)
  REFERENCES locations (id) ON DELETE SET NULL DEFERRABLE INITIALLY DEFERRED;

CREATE TABLE location_frames (
  location_id bigint NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  frame_id bigint NOT NULL REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  PRIMARY KEY (location_id, frame_id)
);
CREATE INDEX location_frames_by_frame ON location_frames (frame_id);

CREATE TABLE vocabulary_imports (
  id bigint PRIMARY KEY,
  session_id bigint REFERENCES sessions (id),
  file text NOT NULL,
  checksum text NOT NULL,
  word_count bigint NOT NULL,
  mode text NOT NULL CHECK (mode IN ('fixed', 'seed')),
  imported_at text NOT NULL,
  extractor text,
  distance_unit text,
  settings text
);

CREATE TABLE words (
  id bigint PRIMARY KEY,
  created_frame bigint REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  vocabulary_import_id bigint REFERENCES vocabulary_imports (id),
  descriptor_type bigint NOT NULL CHECK (descriptor_type IN (0, 1)),
  dim bigint NOT NULL CHECK (dim > 0),
  descriptor bytea NOT NULL
    CHECK (length(descriptor) = dim * (CASE descriptor_type WHEN 0 THEN 4 ELSE 1 END)),
  source_frame bigint,
  checksum bigint
);
CREATE INDEX words_by_created_frame ON words (created_frame);
CREATE INDEX words_imported ON words (id) WHERE vocabulary_import_id IS NOT NULL;

CREATE TABLE word_refs (
  location_id bigint NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  ordinal bigint NOT NULL,
  word_id bigint NOT NULL REFERENCES words (id),
  x double precision NOT NULL,
  y double precision NOT NULL,
  size double precision NOT NULL,
  angle double precision NOT NULL,
  response double precision NOT NULL,
  PRIMARY KEY (location_id, ordinal)
);
CREATE INDEX word_refs_by_word ON word_refs (word_id, location_id);

CREATE TABLE links (
  location_a bigint NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  location_b bigint NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  type bigint NOT NULL CHECK (type IN (0, 1, 2)),
  score double precision,
  PRIMARY KEY (location_a, location_b, type),
  CHECK (location_a < location_b)
);
CREATE INDEX links_by_b ON links (location_b);

CREATE TABLE hypotheses (
  frame_id bigint PRIMARY KEY REFERENCES frames (id) DEFERRABLE INITIALLY DEFERRED,
  best_location_id bigint REFERENCES locations (id) ON DELETE SET NULL,
  posterior double precision NOT NULL,
  loop_probability double precision NOT NULL,
  accepted bigint NOT NULL CHECK (accepted IN (0, 1)),
  rejected_reason text,
  pose_qw double precision,
  pose_qx double precision,
  pose_qy double precision,
  pose_qz double precision,
  pose_tx double precision,
  pose_ty double precision,
  pose_tz double precision,
  pose_inliers bigint
);
CREATE INDEX hypotheses_by_location ON hypotheses (best_location_id);

CREATE TABLE engine_state (
  key text PRIMARY KEY,
  value bytea,
  checksum bigint
);

-- No foreign key on purpose: ids <= 0 stand for the filter's virtual "new place".
CREATE TABLE filter_posterior (
  location_id bigint PRIMARY KEY,
  probability double precision NOT NULL
);

CREATE TABLE kd_nodes (
  tree bigint NOT NULL CHECK (tree >= 0),
  node bigint NOT NULL CHECK (node >= 0),
  left_child bigint NOT NULL,
  right_child bigint NOT NULL,
  split_dim bigint NOT NULL,
  split_value double precision NOT NULL,
  checksum bigint,
  PRIMARY KEY (tree, node)
);

CREATE TABLE place_codes (
  location_id bigint PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  code bytea NOT NULL,
  checksum bigint
);

CREATE TABLE wm_entries (
  location_id bigint PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  wm_age bigint NOT NULL
);

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

CREATE VIEW v_loop_closure_poses AS
SELECT h.frame_id, f.session_id, f.source_index, f.location_id, h.best_location_id,
       h.pose_qx, h.pose_qy, h.pose_qz, h.pose_qw, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers
FROM hypotheses h JOIN frames f ON f.id = h.frame_id
WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL;

CREATE VIEW v_vocabulary_growth AS
SELECT f.session_id, f.source_index, f.id AS frame_id, f.words_created, f.vocabulary_size
FROM frames f;

CREATE VIEW v_kd_trees AS
SELECT tree, count(*) AS internal_nodes, count(*) + 1 AS leaves,
       count(DISTINCT split_dim) AS split_dimensions
FROM kd_nodes GROUP BY tree;
