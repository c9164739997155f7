-- placedb schema 14 on PostgreSQL: no index on locations (tier, weight)
-- (migrations/0014_no_tier_index.sql says why). Here too a tier move changed an indexed column,
-- so no update of a location could be a heap-only one.
DROP INDEX locations_by_tier;
