-- placedb schema 9: the time stamp a frame's source gave it; the pose view in x, y, z, w order. A ROS bag's image message carries
-- one (header.stamp); it is kept as integer nanoseconds since the Unix epoch, so a closure can be
-- matched with the robot's other recordings. NULL for sources without stamps (folders, lists,
-- videos) and for every frame of earlier versions.
ALTER TABLE frames ADD COLUMN stamp_ns INTEGER;
DROP VIEW v_frames;
CREATE VIEW v_frames AS
SELECT f.id AS frame_id, f.session_id, f.source_index, f.source_path,
       CASE f.outcome WHEN 0 THEN 'new' WHEN 1 THEN 'merged' ELSE 'bad' END AS outcome,
       f.location_id, f.feature_count, f.words_created, f.vocabulary_size, f.wm_size, f.stm_size,
       f.mean_quantisation_error, f.features_ms, f.quantisation_ms, f.likelihood_ms, f.filter_ms,
       f.memory_ms, f.storage_ms, f.total_ms, f.stamp_ns
FROM frames f;
-- One quaternion order in every interface (x, y, z, w, as ROS and Eigen use): the view lists
-- the rotation that way; the columns of hypotheses keep their order (a table cannot reorder).
DROP VIEW v_loop_closure_poses;
CREATE VIEW v_loop_closure_poses AS
SELECT h.frame_id, f.session_id, f.source_index, f.location_id, h.best_location_id,
       h.pose_qx, h.pose_qy, h.pose_qz, h.pose_qw, h.pose_tx, h.pose_ty, h.pose_tz, h.pose_inliers
FROM hypotheses h JOIN frames f ON f.id = h.frame_id
WHERE h.accepted = 1 AND h.pose_qw IS NOT NULL;
