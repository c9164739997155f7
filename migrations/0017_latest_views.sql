-- placedb schema 17: nothing changes in a map file. A location's latest merged view is an
-- engine_state row (key 'latest_view/<id>'), which a file takes as any other; schema 17 is the
-- server's (migrations/pg/0017), whose guard must let a robot write it. Both backends keep one
-- schema version, so a file takes the number too.
SELECT 1;
