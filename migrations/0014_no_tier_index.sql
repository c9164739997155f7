-- placedb schema 14: no index on locations (tier, weight). Every frame moves a dozen locations
-- between tiers and changes a weight; each move deleted and inserted one entry of this index, in
-- a page of its own once the map holds tens of thousands of locations: 8 of the 62 pages a
-- frame wrote to the log at 90k frames of the scale run (bench/scale/README.md), and every page
-- written is a page the background checkpoint copies again. Nothing reads it per frame: the
-- engine keeps the tiers in RAM and reads a tier's locations only when it opens a map, and
-- SELECT ... FROM locations WHERE tier = ? still works, as a scan of a small table.
DROP INDEX locations_by_tier;
