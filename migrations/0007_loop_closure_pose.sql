-- placedb schema 7: the relative pose of an accepted loop closure, for pose-graph optimisers.
-- When the session has camera intrinsics (settings fx fy cx cy), the geometric check's inlier
-- pairs give an essential matrix: the rotation (unit quaternion) and the unit translation
-- direction (a monocular check knows no scale) of the frame's camera in the camera of the
-- hypothesis' location, and the pairs that agreed with it. NULL without intrinsics, for a
-- rejected hypothesis and for every hypothesis of earlier versions.
ALTER TABLE hypotheses ADD COLUMN pose_qw REAL;
ALTER TABLE hypotheses ADD COLUMN pose_qx REAL;
ALTER TABLE hypotheses ADD COLUMN pose_qy REAL;
ALTER TABLE hypotheses ADD COLUMN pose_qz REAL;
ALTER TABLE hypotheses ADD COLUMN pose_tx REAL;
ALTER TABLE hypotheses ADD COLUMN pose_ty REAL;
ALTER TABLE hypotheses ADD COLUMN pose_tz REAL;
ALTER TABLE hypotheses ADD COLUMN pose_inliers INTEGER;
CREATE VIEW v_loop_closure_poses AS
SELECT h.frame_id, f.session_id, f.source_index, f.location_id, h.best_location_id,
       h.pose_qw, h.pose_qx, h.pose_qy, h.pose_qz, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers
FROM hypotheses h JOIN frames f ON f.id = h.frame_id
WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL;
