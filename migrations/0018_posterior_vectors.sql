-- placedb schema 18: nothing changes in a map file. A file's writer rewrites its posterior rows in
-- one statement of its own process; schema 18 is the server's (migrations/pg/0018), where those
-- rows cost the server most of a robot's frame. Both backends keep one schema version, so a file
-- takes the number too.
SELECT 1;
