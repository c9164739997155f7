-- placedb schema 9: the time stamp a frame's source gave it. A ROS bag's image message carries
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
