# Sources of placedb_storage. Migrations are embedded into the library at build time; adding or
# editing a migrations/*.sql file re-runs the generator (the glob re-checks at build time).
file(GLOB PLACEDB_MIGRATION_FILES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/migrations/*.sql)
set(PLACEDB_MIGRATIONS_CPP ${CMAKE_CURRENT_BINARY_DIR}/generated/migrations_embedded.cpp)
add_custom_command(
  OUTPUT ${PLACEDB_MIGRATIONS_CPP}
  COMMAND ${CMAKE_COMMAND} -DMIGRATIONS_DIR=${PROJECT_SOURCE_DIR}/migrations
          -DOUTPUT=${PLACEDB_MIGRATIONS_CPP} -P ${CMAKE_CURRENT_LIST_DIR}/cmake/embed_migrations.cmake
  DEPENDS ${PLACEDB_MIGRATION_FILES} ${CMAKE_CURRENT_LIST_DIR}/cmake/embed_migrations.cmake
  COMMENT "Embedding schema migrations into placedb_storage"
  VERBATIM)
# PostgreSQL's scripts (migrations/pg/) begin at 9, the schema version its maps start from.
file(GLOB PLACEDB_PG_MIGRATION_FILES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/migrations/pg/*.sql)
set(PLACEDB_PG_MIGRATIONS_CPP ${CMAKE_CURRENT_BINARY_DIR}/generated/pg_migrations_embedded.cpp)
add_custom_command(
  OUTPUT ${PLACEDB_PG_MIGRATIONS_CPP}
  COMMAND ${CMAKE_COMMAND} -DMIGRATIONS_DIR=${PROJECT_SOURCE_DIR}/migrations/pg
          -DOUTPUT=${PLACEDB_PG_MIGRATIONS_CPP} -DFUNCTION=pgMigrations -DFIRST=9
          -P ${CMAKE_CURRENT_LIST_DIR}/cmake/embed_migrations.cmake
  DEPENDS ${PLACEDB_PG_MIGRATION_FILES} ${CMAKE_CURRENT_LIST_DIR}/cmake/embed_migrations.cmake
  COMMENT "Embedding PostgreSQL schema migrations into placedb_storage"
  VERBATIM)

target_sources(placedb_storage PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/src/map_store.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/map_check.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/migrations.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/map_copy.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/records.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/row_checksums.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/location_rows.cpp
  ${PLACEDB_MIGRATIONS_CPP}
  ${PLACEDB_PG_MIGRATIONS_CPP})
# Includes are written from src/ ("sqlite/database.h"); each backend's room lists its own files.
target_include_directories(placedb_storage PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src)
include(${CMAKE_CURRENT_LIST_DIR}/src/sqlite/sources.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/src/postgres/sources.cmake)
