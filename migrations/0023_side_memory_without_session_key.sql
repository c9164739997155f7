-- placedb schema 23: nothing changes in a map file, whose side-session tables keep their keys on
-- sessions. A server drops them (migrations/pg/0023); both backends keep one schema version, so a
-- file takes the number too.
SELECT 1;
