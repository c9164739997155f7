-- placedb schema 6: a digest of what a session's source held when the session began (the image
-- paths of a folder or list file, in order; a video's size), so that a resume over a source
-- edited in between is refused instead of continuing at an index that now means another image.
-- NULL for sessions of earlier versions: they resume unchecked.
ALTER TABLE sessions ADD COLUMN source_digest TEXT;
