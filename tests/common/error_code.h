#pragma once
// Which placedb::Error a call throws, for tests that check the documented error codes.
#include <exception>
#include <functional>
#include <string>

#include "placedb/error.h"

namespace placedb::testing {

// The code of the placedb::Error that `f` throws; kInternal for any other exception,
// ErrorCode(0) when nothing is thrown. `message` receives the exception's text.
inline ErrorCode codeOf(const std::function<void()>& f, std::string* message = nullptr) {
  try {
    f();
  } catch (const Error& e) {
    if (message) *message = e.what();
    return e.code();
  } catch (const std::exception& e) {
    if (message) *message = e.what();
    return ErrorCode::kInternal;
  }
  return ErrorCode(0);
}

}  // namespace placedb::testing
