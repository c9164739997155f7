-- placedb schema 10: no index on word_refs (word_id). A frame's signature holds a few hundred
-- words spread over the whole vocabulary, so keeping that index dirtied about one page of it per
-- reference, every frame: 40 % of the pages a lip6_outdoor run wrote (bench/quality/README.md).
-- The engine keeps its inverted index in RAM and never read this one; a SQL query by word
-- (SELECT ... FROM word_refs WHERE word_id = ?) still works, as a scan.
DROP INDEX word_refs_by_word;
