-- placedb schema 19: nothing changes in a map file. A word's key on its creating frame costs the
-- server a check per word (migrations/pg/0019); a file checks its keys in its own process at
-- commit. Both backends keep one schema version, so a file takes the number too.
SELECT 1;
