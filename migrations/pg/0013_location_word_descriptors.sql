-- placedb schema 13 on PostgreSQL: the descriptors of each location's words beside it
-- (migrations/0013_location_word_descriptors.sql says why).
CREATE TABLE location_word_descriptors (
  location_id bigint PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  dim bigint NOT NULL CHECK (dim > 0),
  words bytea NOT NULL CHECK (length(words) % (16 + 4 * dim) = 0),
  checksum bigint
);
