-- placedb schema 4: long-term memory that can be searched. Every location keeps a place code, a
-- compact global descriptor of its image (engine/src/memory/place_code.h), whatever its tier, so
-- that a frame is compared with LTM without the words of LTM in RAM. A location brought back
-- from LTM is ranked as new to WM by the transfer order, not by its creation: wm_entries keeps
-- every location's place in that order (its WM age).
CREATE TABLE place_codes (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  code BLOB NOT NULL
);

CREATE TABLE wm_entries (
  location_id INTEGER PRIMARY KEY REFERENCES locations (id) ON DELETE CASCADE,
  wm_age INTEGER NOT NULL
);
