-- placedb schema 16: nothing changes in a map file. Schema 16 is the server's (migrations/pg/0016):
-- its word references lose their per-row foreign key on the word and its large BLOBs their
-- compression attempt. Both backends keep one schema version, so a file takes the number too.
SELECT 1;
