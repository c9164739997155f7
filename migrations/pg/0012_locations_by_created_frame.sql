-- placedb schema 12 on PostgreSQL: the index on locations (created_frame) of migrations/0012.
-- PostgreSQL checks a foreign key from the child's side, so it never scanned here; the index
-- keeps the two schemas alike and serves deleting or renumbering frames.
CREATE INDEX locations_by_created_frame ON locations (created_frame);
