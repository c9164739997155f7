-- placedb schema 2: what an imported vocabulary file said about its words, so that a map made
-- from it exports the same file again (export -> import -> export is byte-identical).

-- The extractor, distance unit and settings named in the file's header.
ALTER TABLE vocabulary_imports ADD COLUMN extractor TEXT;
ALTER TABLE vocabulary_imports ADD COLUMN distance_unit TEXT;
ALTER TABLE vocabulary_imports ADD COLUMN settings TEXT;  -- JSON object, key -> value

-- An imported word's creating frame in the map it came from (frames of that map are not rows
-- of this one, so created_frame stays NULL). NULL for words this map made.
ALTER TABLE words ADD COLUMN source_frame INTEGER;

-- Opening a map reads the imported words' ids: an index holding only those rows keeps that
-- read proportional to the import, not to the whole vocabulary.
CREATE INDEX words_imported ON words (id) WHERE vocabulary_import_id IS NOT NULL;
