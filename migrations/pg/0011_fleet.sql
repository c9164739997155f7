-- placedb schema 11 on PostgreSQL: fleet maps, several writers at once, each in a session of its
-- own (migrations/0011_fleet.sql says what each table holds; schema/SCHEMA.md, "Fleet maps").

CREATE TABLE id_blocks (
  kind text PRIMARY KEY CHECK (kind IN ('frame', 'location', 'word')),
  next bigint NOT NULL
);

CREATE TABLE session_state (
  session_id bigint NOT NULL REFERENCES sessions (id),
  key text NOT NULL,
  value bytea,
  checksum bigint,
  PRIMARY KEY (session_id, key)
);

CREATE TABLE session_kd_nodes (
  session_id bigint NOT NULL REFERENCES sessions (id),
  tree bigint NOT NULL,
  node bigint NOT NULL,
  left_child bigint NOT NULL,
  right_child bigint NOT NULL,
  split_dim bigint NOT NULL,
  split_value double precision NOT NULL,
  checksum bigint,
  PRIMARY KEY (session_id, tree, node)
);

CREATE TABLE session_posterior (
  session_id bigint NOT NULL REFERENCES sessions (id),
  location_id bigint NOT NULL,
  probability double precision NOT NULL,
  PRIMARY KEY (session_id, location_id)
);

CREATE TABLE session_memory (
  session_id bigint NOT NULL REFERENCES sessions (id),
  location_id bigint NOT NULL REFERENCES locations (id) ON DELETE CASCADE,
  tier bigint NOT NULL CHECK (tier IN (0, 1)),
  wm_age bigint,
  PRIMARY KEY (session_id, location_id)
);

-- Each writer asks every frame for the places other sessions stored after the newest it knows
-- of theirs: an index range per session, empty when nothing is new.
DROP INDEX locations_by_session;
CREATE INDEX locations_by_session ON locations (session_id, id);
