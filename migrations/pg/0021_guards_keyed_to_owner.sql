-- placedb schema 21 on PostgreSQL: the map owner's writes pass the guards of schema 15 without
-- running them.
--
-- Every guard trigger (placedb_guard_*) ran for every write statement of every writer, the
-- owner's included, only to find placedb_confined() false and return: ~10 us a statement, about
-- 1 ms of the ~5.5 ms of server CPU a robot frame costs (bench/fleet/statements.sh, issue 47).
-- A trigger's WHEN condition is tested before the trigger is queued, and may call functions but
-- hold no query, so it cannot read the map's owner; each guard now carries the owner's name:
--   WHEN (NOT pg_has_role(CURRENT_USER, 'owner'::name, 'MEMBER'::text))
-- The function behind the guard still asks placedb_confined(), the owner as it is now. A key
-- left by a former owner can therefore only let that role's members skip the guards, never
-- confine the owner; and a key naming a role that no longer exists makes every write of a
-- non-member fail (the role lookup errs) until it is keyed again. placedb_key_guards() keys the
-- guards to the owner of placedb_meta; every writer that is the owner (or a member) runs it when
-- it opens the map (PgMapStore::migrate), so handing a map to another role is followed by one
-- `placedb map` of the new owner. A name rather than an oid: pg_dump keeps role names, not oids.
-- TRUNCATE's guard stays unkeyed: no writer truncates.

-- The owner's membership test, as the server prints it back in a trigger's definition.
CREATE FUNCTION placedb_guard_key() RETURNS text LANGUAGE sql STABLE SET search_path FROM CURRENT
AS $$
  SELECT format('pg_has_role(CURRENT_USER, %L::name, %L::text)', pg_get_userbyid(c.relowner),
                'MEMBER')
  FROM pg_class c WHERE c.oid = 'placedb_meta'::regclass
$$;

-- The guards of this map's schema whose key is not the current owner's, as (name, table, def,
-- keyed_to): keyed_to is the role their condition names (read back from it, where the server
-- prints the name as placedb_guard_key() writes it), NULL for a guard not keyed.
CREATE FUNCTION placedb_unkeyed_guards()
RETURNS TABLE (name name, rel regclass, def text, keyed_to name)
LANGUAGE sql STABLE SET search_path FROM CURRENT AS $$
  SELECT g.tgname, g.rel, g.def,
         replace(substring(g.def FROM
                           $re$pg_has_role\(CURRENT_USER, '((?:[^']|'')*)'::name, 'MEMBER'::text\)$re$),
                 '''''', '''')::name
  FROM (SELECT t.tgname, t.tgrelid::regclass AS rel, pg_get_triggerdef(t.oid) AS def
        FROM pg_trigger t JOIN pg_class c ON c.oid = t.tgrelid
        WHERE c.relnamespace = (SELECT relnamespace FROM pg_class
                                WHERE oid = 'placedb_meta'::regclass)
          AND t.tgname IN ('placedb_guard_insert', 'placedb_guard_update', 'placedb_guard_delete'))
       g
  WHERE position(placedb_guard_key() IN g.def) = 0
  ORDER BY 2, 1
$$;

-- Keys every guard to the map's owner; a confined role changes nothing. The number re-keyed.
CREATE FUNCTION placedb_key_guards() RETURNS integer LANGUAGE plpgsql
SET search_path FROM CURRENT AS $$
DECLARE
  g record;
  keyed integer := 0;
BEGIN
  IF placedb_confined() THEN
    RETURN 0;
  END IF;
  FOR g IN SELECT * FROM placedb_unkeyed_guards() LOOP
    EXECUTE format('DROP TRIGGER %I ON %s', g.name, g.rel);
    EXECUTE replace(regexp_replace(g.def, ' WHEN \(.*\) EXECUTE FUNCTION ', ' EXECUTE FUNCTION '),
                    ' EXECUTE FUNCTION ', ' WHEN (NOT ' || placedb_guard_key() || ') EXECUTE FUNCTION ');
    keyed := keyed + 1;
  END LOOP;
  RETURN keyed;
END $$;

SELECT placedb_key_guards();
