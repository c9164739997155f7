-- placedb schema 17 on PostgreSQL: a location's second engine_state row. A location keeps the
-- view of the latest frame merged into it under 'latest_view/<id>' (engine/src/geometry/
-- latest_view.h), written by the writer whose session made the location, as its
-- 'keypoint_descriptors/<id>' row is. The guard of 0015 judged every other engine_state key the
-- main line's, so a confined robot could not write its own places' views; it now judges both keys
-- by their location's session. The function is replaced whole (PL/pgSQL has no partial edit); only
-- the 'state' case differs from 0015's.
CREATE OR REPLACE FUNCTION placedb_guard() RETURNS trigger LANGUAGE plpgsql SET search_path FROM CURRENT AS $$
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
          'CASE WHEN r.key ~ ''^(keypoint_descriptors|latest_view)/[0-9]{1,18}$'' THEN ' ||
          format(own_location, 'CAST(split_part(r.key, ''/'', 2) AS bigint)') ||
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
