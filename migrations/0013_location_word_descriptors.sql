-- placedb schema 13: the descriptors of each location's words, stored beside it. Bringing a
-- location back from long-term memory needs the words of its signature that left RAM; in the
-- words table they lie wherever their ids put them (a location's 97 words in some 34 runs of
-- ids on the scale map), so each retrieval read as many pages scattered over a table of 1.2 GB
-- that SQLite's cache holds little of, and cost more as the map grew. One row per location makes
-- it one read. The words table stays what it was, the one record of every word: rows here are
-- copies, written with the location and never changed. Locations made before have no row and are
-- read from the words table (schema/SCHEMA.md).
CREATE TABLE location_word_descriptors (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  dim INTEGER NOT NULL CHECK (dim > 0),
  words BLOB NOT NULL CHECK (length(words) % (16 + 4 * dim) = 0),
  checksum INTEGER
);
