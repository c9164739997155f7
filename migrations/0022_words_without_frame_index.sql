-- placedb schema 22: nothing changes in a map file, which keeps words_by_created_frame for its
-- deferred foreign key. A server drops the index (migrations/pg/0022); both backends keep one
-- schema version, so a file takes the number too.
SELECT 1;
