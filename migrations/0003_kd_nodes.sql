-- placedb schema 3: the vocabulary's kd-forest stored as its current internal nodes, one row
-- each, updated every frame. Schema 2 kept an append-only log of every split ever made (in
-- engine_state, 'vocabulary.splits.*'), so reopening a map replayed the whole history of the
-- vocabulary; the node table follows the words in RAM only. The engine converts the log of a
-- schema-2 map when it first opens it and writes this table (and drops the log) with the next
-- frame it commits.
CREATE TABLE kd_nodes (
  tree INTEGER NOT NULL CHECK (tree >= 0),
  node INTEGER NOT NULL CHECK (node >= 0),
  left_child INTEGER NOT NULL,
  right_child INTEGER NOT NULL,
  split_dim INTEGER NOT NULL,
  split_value REAL NOT NULL,
  PRIMARY KEY (tree, node)
) WITHOUT ROWID;

-- Size and shape of each kd-tree: internal nodes, leaves (one more than the internal nodes of a
-- binary tree) and the dimensions it splits on.
CREATE VIEW v_kd_trees AS
SELECT tree, count(*) AS internal_nodes, count(*) + 1 AS leaves,
       count(DISTINCT split_dim) AS split_dimensions
FROM kd_nodes GROUP BY tree;
