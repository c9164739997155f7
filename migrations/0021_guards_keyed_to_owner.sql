-- placedb schema 21: nothing changes in a map file. A server keys its guard triggers to the map's
-- owner (migrations/pg/0021); both backends keep one schema version, so a file takes the number
-- too.
SELECT 1;
