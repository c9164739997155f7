-- placedb schema 18 on PostgreSQL: a writer's filter posterior as one row of arrays.
--
-- The Bayes filter's normalisation changes every entry of the posterior every frame, so a writer
-- rewrote its whole working memory's rows each frame (~760 on lip6): the largest part of the
-- server's CPU per robot frame, and as many dead rows for vacuum to reclaim (issue 47;
-- bench/fleet/README.md). A writer's posterior is now one row holding its ids, probabilities and
-- row checksums as arrays, written by one upsert. `filter_posterior` and `session_posterior` stay
-- as views with the tables' columns, so every query of SCHEMA.md reads them unchanged, and SQL by
-- hand (or `placedb copy`) that inserts, updates or deletes their rows changes the arrays through
-- the triggers below, keys and all.
ALTER TABLE filter_posterior RENAME TO filter_posterior_rows;
ALTER TABLE session_posterior RENAME TO session_posterior_rows;

CREATE TABLE filter_posterior_vector (
  one_row boolean PRIMARY KEY DEFAULT true CHECK (one_row),
  location_ids bigint[] NOT NULL,
  probabilities double precision[] NOT NULL,
  checksums bigint[] NOT NULL,
  CHECK (cardinality(probabilities) = cardinality(location_ids) AND
         cardinality(checksums) = cardinality(location_ids) AND
         array_position(location_ids, NULL) IS NULL AND
         array_position(probabilities, NULL) IS NULL)
);

CREATE TABLE session_posterior_vectors (
  session_id bigint PRIMARY KEY REFERENCES sessions (id),
  location_ids bigint[] NOT NULL,
  probabilities double precision[] NOT NULL,
  CHECK (cardinality(probabilities) = cardinality(location_ids) AND
         array_position(location_ids, NULL) IS NULL AND
         array_position(probabilities, NULL) IS NULL)
);

-- Float probabilities do not compress (migrations/pg/0016 says what trying cost).
ALTER TABLE filter_posterior_vector ALTER COLUMN probabilities SET STORAGE EXTERNAL,
  ALTER COLUMN checksums SET STORAGE EXTERNAL, ALTER COLUMN location_ids SET STORAGE EXTERNAL;
ALTER TABLE session_posterior_vectors ALTER COLUMN probabilities SET STORAGE EXTERNAL,
  ALTER COLUMN location_ids SET STORAGE EXTERNAL;

INSERT INTO filter_posterior_vector (location_ids, probabilities, checksums)
SELECT array_agg(location_id ORDER BY location_id), array_agg(probability ORDER BY location_id),
       array_agg(checksum ORDER BY location_id)
FROM filter_posterior_rows HAVING count(*) > 0;

INSERT INTO session_posterior_vectors (session_id, location_ids, probabilities)
SELECT session_id, array_agg(location_id ORDER BY location_id),
       array_agg(probability ORDER BY location_id)
FROM session_posterior_rows GROUP BY session_id;

CREATE VIEW filter_posterior AS
SELECT p.location_id, p.probability, p.checksum
FROM filter_posterior_vector v,
     unnest(v.location_ids, v.probabilities, v.checksums) AS p(location_id, probability, checksum);

CREATE VIEW session_posterior AS
SELECT v.session_id, p.location_id, p.probability
FROM session_posterior_vectors v,
     unnest(v.location_ids, v.probabilities) AS p(location_id, probability);

-- A row written through a view: the arrays of its writer read, changed and written back. The
-- tables' keys are enforced here (location_id unique per writer, no NULL id or probability).
CREATE FUNCTION placedb_posterior_row() RETURNS trigger LANGUAGE plpgsql
SET search_path FROM CURRENT AS $$
DECLARE
  side constant boolean := TG_TABLE_NAME = 'session_posterior';
  writer bigint;
  old_id bigint;
  new_id bigint;
  ids bigint[];
  ps double precision[];
  sums bigint[];
  i int;
BEGIN
  -- OLD and NEW are read only where the operation has them, and session_id only on the view
  -- that has it.
  IF TG_OP <> 'INSERT' THEN
    old_id := OLD.location_id;
    IF side THEN writer := OLD.session_id; END IF;
  END IF;
  IF TG_OP <> 'DELETE' THEN
    new_id := NEW.location_id;
    IF new_id IS NULL OR NEW.probability IS NULL THEN
      RAISE EXCEPTION '% row % has a NULL location_id or probability', TG_TABLE_NAME, NEW
        USING ERRCODE = 'not_null_violation';
    END IF;
    IF side THEN
      IF NEW.session_id IS NULL OR (TG_OP = 'UPDATE' AND NEW.session_id <> writer) THEN
        RAISE EXCEPTION 'session_posterior row % names no session or another one than before',
          NEW USING ERRCODE = 'feature_not_supported';
      END IF;
      writer := NEW.session_id;
    END IF;
  END IF;
  IF side THEN
    SELECT v.location_ids, v.probabilities INTO ids, ps
    FROM session_posterior_vectors v WHERE v.session_id = writer FOR UPDATE;
  ELSE
    SELECT v.location_ids, v.probabilities, v.checksums INTO ids, ps, sums
    FROM filter_posterior_vector v FOR UPDATE;
  END IF;
  ids := coalesce(ids, '{}');
  ps := coalesce(ps, '{}');
  sums := coalesce(sums, '{}');
  IF new_id = ANY (ids) AND new_id IS DISTINCT FROM old_id THEN
    RAISE EXCEPTION 'duplicate key value: % already holds location_id %', TG_TABLE_NAME, new_id
      USING ERRCODE = 'unique_violation';
  END IF;
  IF TG_OP = 'INSERT' THEN
    ids := ids || new_id;
    ps := ps || NEW.probability;
    IF NOT side THEN sums := sums || NEW.checksum; END IF;
  ELSE
    i := array_position(ids, old_id);
    IF TG_OP = 'UPDATE' THEN
      ids[i] := new_id;
      ps[i] := NEW.probability;
      IF NOT side THEN sums[i] := NEW.checksum; END IF;
    ELSE
      ids := ids[:i - 1] || ids[i + 1:];
      ps := ps[:i - 1] || ps[i + 1:];
      IF NOT side THEN sums := sums[:i - 1] || sums[i + 1:]; END IF;
    END IF;
  END IF;
  IF side THEN
    INSERT INTO session_posterior_vectors AS v VALUES (writer, ids, ps)
    ON CONFLICT (session_id) DO UPDATE SET location_ids = excluded.location_ids,
      probabilities = excluded.probabilities;
  ELSE
    INSERT INTO filter_posterior_vector AS v VALUES (true, ids, ps, sums)
    ON CONFLICT (one_row) DO UPDATE SET location_ids = excluded.location_ids,
      probabilities = excluded.probabilities, checksums = excluded.checksums;
  END IF;
  IF TG_OP = 'DELETE' THEN
    RETURN OLD;
  END IF;
  RETURN NEW;
END $$;

CREATE TRIGGER placedb_posterior_row INSTEAD OF INSERT OR UPDATE OR DELETE ON filter_posterior
FOR EACH ROW EXECUTE FUNCTION placedb_posterior_row();
CREATE TRIGGER placedb_posterior_row INSTEAD OF INSERT OR UPDATE OR DELETE ON session_posterior
FOR EACH ROW EXECUTE FUNCTION placedb_posterior_row();

-- The guards of migrations/pg/0015, on the tables that now hold the rows: the main line's
-- posterior is the main line's writer's, a side session's its own.
CREATE TRIGGER placedb_guard_truncate BEFORE TRUNCATE ON filter_posterior_vector
FOR EACH STATEMENT EXECUTE FUNCTION placedb_owner_only();
CREATE TRIGGER placedb_guard_insert BEFORE INSERT ON filter_posterior_vector
FOR EACH STATEMENT EXECUTE FUNCTION placedb_main_line_only();
CREATE TRIGGER placedb_guard_update BEFORE UPDATE ON filter_posterior_vector
FOR EACH STATEMENT EXECUTE FUNCTION placedb_main_line_only();
CREATE TRIGGER placedb_guard_delete BEFORE DELETE ON filter_posterior_vector
FOR EACH STATEMENT EXECUTE FUNCTION placedb_main_line_only();
CREATE TRIGGER placedb_guard_truncate BEFORE TRUNCATE ON session_posterior_vectors
FOR EACH STATEMENT EXECUTE FUNCTION placedb_owner_only();
CREATE TRIGGER placedb_guard_insert AFTER INSERT ON session_posterior_vectors
REFERENCING NEW TABLE AS new_rows
FOR EACH STATEMENT EXECUTE FUNCTION placedb_guard('side:session_id');
CREATE TRIGGER placedb_guard_update AFTER UPDATE ON session_posterior_vectors
REFERENCING OLD TABLE AS old_rows NEW TABLE AS new_rows
FOR EACH STATEMENT EXECUTE FUNCTION placedb_guard('side:session_id');
CREATE TRIGGER placedb_guard_delete AFTER DELETE ON session_posterior_vectors
REFERENCING OLD TABLE AS old_rows
FOR EACH STATEMENT EXECUTE FUNCTION placedb_guard('side:session_id');

-- The roles granted the old tables (SCHEMA.md's robots) keep what they could do: the same
-- privileges on the view and on the table behind it, whose triggers run as the role that writes.
DO $$
DECLARE
  g record;
BEGIN
  FOR g IN
    SELECT CASE c.relname WHEN 'filter_posterior_rows' THEN 'filter_posterior'
                          ELSE 'session_posterior' END AS view_name,
           CASE c.relname WHEN 'filter_posterior_rows' THEN 'filter_posterior_vector'
                          ELSE 'session_posterior_vectors' END AS table_name,
           CASE a.grantee WHEN 0 THEN 'PUBLIC' ELSE a.grantee::regrole::text END AS grantee,
           string_agg(a.privilege_type, ', ') AS privileges
    FROM pg_class c, aclexplode(c.relacl) a
    WHERE c.oid IN ('filter_posterior_rows'::regclass, 'session_posterior_rows'::regclass)
      AND a.grantee <> c.relowner
    GROUP BY 1, 2, 3
  LOOP
    EXECUTE format('GRANT %s ON %I, %I TO %s', g.privileges, g.view_name, g.table_name,
                   g.grantee);
  END LOOP;
END $$;

DROP TABLE filter_posterior_rows;
DROP TABLE session_posterior_rows;
