-- placedb schema 15 on PostgreSQL: what each location's rows must hold, and sums on the WM ages
-- and the posterior (migrations/0015_location_rows.sql says why). The runner fills them in for
-- the rows an older map holds.
ALTER TABLE locations ADD COLUMN held bigint;
ALTER TABLE locations ADD COLUMN refs_digest bigint;
ALTER TABLE locations ADD COLUMN checksum bigint;
ALTER TABLE locations ADD COLUMN link_count bigint;
ALTER TABLE wm_entries ADD COLUMN checksum bigint;
ALTER TABLE filter_posterior ADD COLUMN checksum bigint;
ALTER TABLE sessions ADD COLUMN settings_digest bigint;

-- Robots confined to their own sessions' rows (schema/SCHEMA.md, "Roles"). Grants alone cannot do
-- it: a robot needs UPDATE on locations to move any place between the main line's tiers, yet must
-- not change another robot's place, and any writer could rewrite the schema version in
-- placedb_meta (locking out the fleet) or delete every location. Which role began each session
-- is kept with it (a session begun before schema 15 is the owner's), and triggers owned by the
-- map's owner refuse (SQLSTATE 42501, as a missing privilege) a write by a role that is not the
-- owner (nor a member of it) to: the metadata and the vocabulary imports, and any TRUNCATE;
-- rows of another role's session (its frames, places, references, links between two such
-- places, settings, its own memory); the main line's memory (kd_nodes, filter_posterior,
-- wm_entries, engine_state but keypoint rows, locations' tiers) unless the writer holds the main
-- line's lock; and deletes and updates no writer of a map makes. What only the owner writes, and
-- the main line's memory, are judged before the statement runs (so before any foreign key's own
-- error, and with no copy of the rows: the main line's writes are most of a frame's); the rest
-- once a statement, after it, on the rows it wrote (transition tables): the owner's writers pay
-- a call each. Cascades (ON DELETE CASCADE) run as the tables' owner and pass.
ALTER TABLE sessions ADD COLUMN owner_role name NOT NULL DEFAULT current_user;

CREATE FUNCTION placedb_confined() RETURNS boolean LANGUAGE sql STABLE SET search_path FROM CURRENT
AS $$
  SELECT NOT pg_has_role(current_user,
                         (SELECT c.relowner FROM pg_class c WHERE c.oid = 'placedb_meta'::regclass),
                         'MEMBER')
$$;

-- The main line's advisory lock, 1347175490 (pg_try_advisory_lock(bigint): classid 0, objid the
-- key, objsubid 1), held by this connection.
CREATE FUNCTION placedb_holds_main_line() RETURNS boolean LANGUAGE sql STABLE AS $$
  SELECT EXISTS (SELECT 1 FROM pg_locks WHERE locktype = 'advisory' AND pid = pg_backend_pid()
                 AND granted AND classid = 0::oid AND objid = 1347175490::oid AND objsubid = 1)
$$;

-- Before a statement on what only the map's owner writes (and before any TRUNCATE).
CREATE FUNCTION placedb_owner_only() RETURNS trigger LANGUAGE plpgsql SET search_path FROM CURRENT
AS $$
BEGIN
  IF placedb_confined() THEN
    RAISE EXCEPTION 'role % may not % %: only the map''s owner does', current_user, lower(TG_OP),
      TG_TABLE_NAME USING ERRCODE = '42501';
  END IF;
  RETURN NULL;
END $$;

-- Before a statement on the main line's memory: its writer holds the main line.
CREATE FUNCTION placedb_main_line_only() RETURNS trigger LANGUAGE plpgsql
SET search_path FROM CURRENT AS $$
BEGIN
  IF placedb_confined() AND NOT placedb_holds_main_line() THEN
    RAISE EXCEPTION 'role % may not % %: it is the main line''s memory, and this writer does not '
      'hold the main line', current_user, lower(TG_OP), TG_TABLE_NAME USING ERRCODE = '42501';
  END IF;
  RETURN NULL;
END $$;

-- TG_ARGV[0] says whose a row is: 'sessions'
-- (a sessions row: the role it names), 'session:COL' (the session COL names), 'side:COL' (a
-- session's own memory: its role, or the main line's holder keeping a killed writer's memory),
-- 'location:COL' (the location COL names), 'links' (either end), 'state' (engine_state: a
-- keypoint row is its location's, any other key the main line's).
CREATE FUNCTION placedb_guard() RETURNS trigger LANGUAGE plpgsql SET search_path FROM CURRENT AS $$
DECLARE
  how text := split_part(TG_ARGV[0], ':', 1);
  col text := split_part(TG_ARGV[0], ':', 2);
  relation text;
  foreign_row text;
  own_session constant text :=
    'EXISTS (SELECT 1 FROM sessions s WHERE s.id = %s AND s.owner_role = current_user)';
  own_location constant text :=
    'EXISTS (SELECT 1 FROM locations l JOIN sessions s ON s.id = l.session_id '
    'WHERE l.id = %s AND s.owner_role = current_user)';
BEGIN
  IF NOT placedb_confined() THEN
    RETURN NULL;
  END IF;
  FOREACH relation IN ARRAY CASE TG_OP WHEN 'INSERT' THEN ARRAY['new_rows']
                                       WHEN 'DELETE' THEN ARRAY['old_rows']
                                       ELSE ARRAY['old_rows', 'new_rows'] END LOOP
    EXECUTE format('SELECT r::text FROM %I r WHERE NOT (%s) LIMIT 1', relation,
      CASE how
        WHEN 'sessions' THEN 'r.owner_role = current_user'
        WHEN 'session' THEN format(own_session, 'r.' || quote_ident(col))
        WHEN 'side' THEN format(own_session, 'r.' || quote_ident(col)) ||
                         ' OR placedb_holds_main_line()'
        WHEN 'location' THEN format(own_location, 'r.' || quote_ident(col))
        WHEN 'links' THEN format(own_location, 'r.location_a') || ' OR ' ||
                          format(own_location, 'r.location_b')
        WHEN 'state' THEN
          'CASE WHEN r.key ~ ''^keypoint_descriptors/[0-9]{1,18}$'' THEN ' ||
          format(own_location, 'CAST(substr(r.key, 22) AS bigint)') ||
          ' ELSE placedb_holds_main_line() END'
      END)
      INTO foreign_row;
    IF foreign_row IS NOT NULL THEN
      RAISE EXCEPTION 'role % may not % % row %: it belongs to another role''s session',
        current_user, lower(TG_OP), TG_TABLE_NAME, foreign_row USING ERRCODE = '42501';
    END IF;
  END LOOP;
  RETURN NULL;
END $$;

-- A place of another role's session may move between the main line's tiers and be marked as
-- having a WM row (held bit 8), both by the writer that holds the main line, and count the links
-- it has (a link to it added or removed in the same statement), nothing else.
CREATE FUNCTION placedb_guard_locations() RETURNS trigger LANGUAGE plpgsql
SET search_path FROM CURRENT AS $$
DECLARE
  foreign_row text;
BEGIN
  IF NOT placedb_confined() THEN
    RETURN NULL;
  END IF;
  SELECT n::text INTO foreign_row FROM old_rows o JOIN new_rows n ON n.id = o.id
  WHERE n.session_id IS DISTINCT FROM o.session_id
     OR (n.tier IS DISTINCT FROM o.tier AND NOT placedb_holds_main_line())
     OR (NOT EXISTS (SELECT 1 FROM sessions s WHERE s.id = o.session_id
                     AND s.owner_role = current_user)
         AND ((n.weight, n.created_frame, n.refs_digest, n.checksum)
              IS DISTINCT FROM (o.weight, o.created_frame, o.refs_digest, o.checksum)
              OR (n.held IS DISTINCT FROM o.held
                  AND (coalesce(n.held, 0) # coalesce(o.held, 0) <> 8
                       OR NOT placedb_holds_main_line()))
              OR (n.link_count IS DISTINCT FROM o.link_count
                  AND n.link_count IS DISTINCT FROM
                      (SELECT count(*) FROM links k WHERE k.location_a = n.id
                       OR k.location_b = n.id))))
  LIMIT 1;
  IF foreign_row IS NOT NULL THEN
    RAISE EXCEPTION 'role % may not update locations row %: it belongs to another role''s session '
      '(only its tier and WM mark, by the main line''s holder, and its link count may change)',
      current_user, foreign_row USING ERRCODE = '42501';
  END IF;
  RETURN NULL;
END $$;

-- ins, upd, del: how each write is judged ('owner' and 'main_line' before the statement, NULL
-- none, else placedb_guard's argument, 'locations' placedb_guard_locations); TRUNCATE is the
-- owner's.
CREATE FUNCTION placedb_guard_table(tab text, ins text, upd text, del text) RETURNS void
LANGUAGE plpgsql AS $$
DECLARE
  op text;
  how text;
BEGIN
  EXECUTE format('CREATE TRIGGER placedb_guard_truncate BEFORE TRUNCATE ON %I '
                 'FOR EACH STATEMENT EXECUTE FUNCTION placedb_owner_only()', tab);
  FOREACH op IN ARRAY ARRAY['insert', 'update', 'delete'] LOOP
    how := CASE op WHEN 'insert' THEN ins WHEN 'update' THEN upd ELSE del END;
    IF how IN ('owner', 'main_line') THEN
      EXECUTE format('CREATE TRIGGER placedb_guard_%s BEFORE %s ON %I '
                     'FOR EACH STATEMENT EXECUTE FUNCTION placedb_%s_only()', op, op, tab, how);
    ELSIF how IS NOT NULL THEN
      EXECUTE format('CREATE TRIGGER placedb_guard_%s AFTER %s ON %I REFERENCING %s '
                     'FOR EACH STATEMENT EXECUTE FUNCTION %s', op, op, tab,
                     CASE op WHEN 'insert' THEN 'NEW TABLE AS new_rows'
                             WHEN 'delete' THEN 'OLD TABLE AS old_rows'
                             ELSE 'OLD TABLE AS old_rows NEW TABLE AS new_rows' END,
                     CASE how WHEN 'locations' THEN 'placedb_guard_locations()'
                              ELSE format('placedb_guard(%L)', how) END);
    END IF;
  END LOOP;
END $$;

SELECT placedb_guard_table('placedb_meta', 'owner', 'owner', 'owner'),
       placedb_guard_table('vocabulary_imports', 'owner', 'owner', 'owner'),
       placedb_guard_table('sessions', 'sessions', 'sessions', 'owner'),
       placedb_guard_table('settings', 'session:session_id', 'owner', 'owner'),
       placedb_guard_table('frames', 'session:session_id', 'owner', 'owner'),
       placedb_guard_table('hypotheses', NULL, 'owner', 'owner'),
       placedb_guard_table('words', NULL, 'owner', 'owner'),
       placedb_guard_table('locations', 'session:session_id', 'locations', 'session:session_id'),
       placedb_guard_table('location_frames', 'location:location_id', 'owner', 'owner'),
       placedb_guard_table('word_refs', 'location:location_id', 'owner', 'owner'),
       placedb_guard_table('place_codes', 'location:location_id', 'location:location_id', 'owner'),
       placedb_guard_table('location_word_descriptors', 'location:location_id',
                           'location:location_id', 'owner'),
       placedb_guard_table('links', 'links', 'links', 'owner'),
       placedb_guard_table('engine_state', 'state', 'state', 'state'),
       placedb_guard_table('kd_nodes', 'main_line', 'main_line', 'main_line'),
       placedb_guard_table('filter_posterior', 'main_line', 'main_line', 'main_line'),
       placedb_guard_table('wm_entries', 'main_line', 'main_line', 'main_line'),
       placedb_guard_table('id_blocks', NULL, NULL, 'owner'),
       placedb_guard_table('session_state', 'side:session_id', 'side:session_id',
                           'side:session_id'),
       placedb_guard_table('session_kd_nodes', 'side:session_id', 'side:session_id',
                           'side:session_id'),
       placedb_guard_table('session_posterior', 'side:session_id', 'side:session_id',
                           'side:session_id'),
       placedb_guard_table('session_memory', 'side:session_id', 'side:session_id',
                           'side:session_id');
DROP FUNCTION placedb_guard_table(text, text, text, text);
