-- placedb schema 12: an index on locations (created_frame). The column is a deferred foreign key
-- to frames, and a frame's row goes in after the words and location that name it: SQLite then
-- looks, at that insert, for the child rows that now have their parent, and without an index
-- that look is a scan of every location. On the 100k-frame scale map (42k locations) it was
-- most of a frame's storage time, growing with the map (bench/scale/README.md).
CREATE INDEX locations_by_created_frame ON locations (created_frame);
