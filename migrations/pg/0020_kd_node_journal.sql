-- placedb schema 20 on PostgreSQL: nothing changes on a server. A map file journals its
-- kd-forest changes (migrations/0020); a server writes kd_nodes as before. Both backends keep
-- one schema version, so a server takes the number too.
SELECT 1;
