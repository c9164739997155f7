// The schema version both backends report: the last of the embedded migrations.
#include "placedb/storage/migrations.h"

namespace placedb::storage {

int currentSchemaVersion() { return migrations().empty() ? 0 : migrations().back().version; }

}  // namespace placedb::storage
