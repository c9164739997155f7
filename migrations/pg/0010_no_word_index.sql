-- placedb schema 10 on PostgreSQL: no index on word_refs (word_id), as in migrations/0010 (a
-- frame's references spread over the whole vocabulary, so the index took a page write per
-- reference; the engine keeps the inverted index in RAM).
DROP INDEX word_refs_by_word;
