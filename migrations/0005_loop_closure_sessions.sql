-- placedb schema 5: v_loop_closures names the session that made each side, so that a closure
-- between two sessions can be told from one within a session without joining locations.
DROP VIEW v_loop_closures;
CREATE VIEW v_loop_closures AS
SELECT k.location_a, k.location_b, k.score,
       (SELECT min(fa.source_index) FROM location_frames lfa JOIN frames fa ON fa.id = lfa.frame_id
         WHERE lfa.location_id = k.location_a) AS first_frame_a,
       (SELECT min(fb.source_index) FROM location_frames lfb JOIN frames fb ON fb.id = lfb.frame_id
         WHERE lfb.location_id = k.location_b) AS first_frame_b,
       (SELECT la.session_id FROM locations la WHERE la.id = k.location_a) AS session_a,
       (SELECT lb.session_id FROM locations lb WHERE lb.id = k.location_b) AS session_b
FROM links k WHERE k.type = 1;
